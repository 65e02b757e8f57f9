#include "pnsplat/refine/text.h"

#include <cmath>

#include <fmt/core.h>

namespace pnsplat {

std::string jsonNumber(double v) {
    return std::isfinite(v) ? fmt::format("{}", v) : std::string("null");
}

std::string jsonString(std::string_view s) {
    std::string out = "\"";
    for (const char ch : s) {
        switch (ch) {
        case '"':
            out += "\\\"";
            break;
        case '\\':
            out += "\\\\";
            break;
        case '\n':
            out += "\\n";
            break;
        case '\r':
            out += "\\r";
            break;
        case '\t':
            out += "\\t";
            break;
        default:
            if (static_cast<unsigned char>(ch) < 0x20)
                out += fmt::format("\\u{:04x}", static_cast<unsigned>(static_cast<unsigned char>(ch)));
            else
                out += ch;
        }
    }
    return out + "\"";
}

} // namespace pnsplat
