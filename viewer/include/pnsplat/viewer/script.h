// A script of timed events for a viewer session (docs/VIEWER.md, "Scripts"): tests and recorded
// demos replay input through it. One command a line,
//
//     FRAME COMMAND [ARGUMENTS]
//
// FRAME counts the script's frames from 0 (the first frame drawn); commands of one frame run in the
// file's order, and frames must not decrease. Commands: key NAME (press and release), keydown NAME,
// keyup NAME, move X Y, press BUTTON, release BUTTON, drag BUTTON X0 Y0 X1 Y1 FRAMES, wheel STEPS,
// resize W H, minimize, restore, drop FILE, screenshot FILE, settle, quit. Blank lines and text
// from a `#` that starts a word are ignored.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <istream>
#include <string>
#include <vector>

#include "pnsplat/refine/result.h"
#include "pnsplat/viewer/events.h"

namespace pnsplat::viewer {

class Script {
  public:
    // Reads a script; `name` names it in errors ("NAME:LINE: what is wrong").
    static Result<Script> parse(std::istream& in, const std::string& name);
    // Reads the script file at `path` (an error names the file when it cannot be read).
    static Result<Script> load(const std::filesystem::path& path);

    // The events due at or before script frame `frame` that were not taken yet, in order, up to the
    // first Settle (included): the viewer holds the script's clock until the view has settled, and
    // takes the rest of the frame's events then.
    std::vector<Event> take(std::uint64_t frame);
    // Every event has been taken.
    bool finished() const { return next_ == steps_.size(); }
    // The last frame with an event (0 for an empty script).
    std::uint64_t lastFrame() const { return steps_.empty() ? 0 : steps_.back().frame; }
    std::size_t size() const { return steps_.size(); }

  private:
    struct Step {
        std::uint64_t frame;
        Event event;
    };
    std::vector<Step> steps_; // by frame, then in the file's order
    std::size_t next_ = 0;
};

} // namespace pnsplat::viewer
