#include "progress.h"

#include <cstdio>
#include <unistd.h>

#include <fmt/core.h>

namespace pnsplat::tools {

ProgressBar::ProgressBar(std::string label)
    : label_(std::move(label)), enabled_(isatty(STDERR_FILENO) != 0) {}

ProgressBar::~ProgressBar() {
    finish();
}

void ProgressBar::setLabel(std::string label) {
    label_ = std::move(label);
    last_ = {}; // the next update draws the new label
}

void ProgressBar::update(std::size_t done, std::size_t total) {
    if (!enabled_ || total == 0) return;
    const auto now = std::chrono::steady_clock::now();
    if (drawn_ && done < total && now - last_ < std::chrono::milliseconds(50)) return;
    last_ = now;
    constexpr int kWidth = 30;
    const double fraction = std::min(1.0, static_cast<double>(done) / static_cast<double>(total));
    const int filled = static_cast<int>(fraction * kWidth);
    fmt::print(stderr, "\r{} [{:=<{}}{: <{}}] {:5.1f}%", label_, "", filled, "", kWidth - filled,
               100.0 * fraction);
    std::fflush(stderr);
    drawn_ = true;
}

void ProgressBar::finish() {
    if (!drawn_) return;
    fmt::print(stderr, "\r\033[K");
    std::fflush(stderr);
    drawn_ = false;
}

} // namespace pnsplat::tools
