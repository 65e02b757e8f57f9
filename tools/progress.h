// A one-line progress bar on standard error, drawn only when standard error is a terminal.
#pragma once

#include <chrono>
#include <cstddef>
#include <string>

namespace pnsplat::tools {

class ProgressBar {
  public:
    explicit ProgressBar(std::string label);
    ~ProgressBar();
    ProgressBar(const ProgressBar&) = delete;
    ProgressBar& operator=(const ProgressBar&) = delete;

    void setLabel(std::string label); // drawn at the next update, whenever that comes
    // Redraws at most ~20 times a second.
    void update(std::size_t done, std::size_t total);
    // Clears the line.
    void finish();

  private:
    std::string label_;
    bool enabled_;
    bool drawn_ = false;
    std::chrono::steady_clock::time_point last_{};
};

} // namespace pnsplat::tools
