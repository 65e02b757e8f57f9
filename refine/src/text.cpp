#include "pnsplat/refine/text.h"

#include <algorithm>
#include <cmath>

#include <fmt/core.h>

namespace pnsplat {

std::string placeText(glm::dvec3 place, double size, char separator) {
    std::string text;
    for (int axis = 0; axis < 3; ++axis) {
        const double value = place[axis];
        if (axis > 0) text += separator;
        if (!std::isfinite(value) || !(size > 0.0)) {
            text += fmt::format("{}", value);
            continue;
        }
        const double magnitude = std::max(std::abs(value), size);
        const int digits = 4 + std::max(0, static_cast<int>(std::ceil(std::log10(magnitude / size))));
        // Where the whole part, rounded, has more digits than that (a size of 10,000 or more), %g
        // writes an exponent ("2.8733e+05"): the whole number instead, rounded to those digits, up
        // to the 16 whole digits a double holds.
        const std::string general = fmt::format("{:.{}g}", value, digits);
        const std::size_t e = general.find("e+");
        const int exponent = e == std::string::npos ? 0 : std::stoi(general.substr(e + 2));
        if (exponent > 0 && exponent < 16) {
            const double step = std::pow(10.0, exponent - digits + 1);
            text += fmt::format("{:.0f}", std::round(value / step) * step);
        } else {
            text += general;
        }
    }
    return text;
}

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
