// The JSON of the real-time engine's frames, for `bench view` and the viewer's --stats: one line per
// frame, and a summary of a series.
#pragma once

#include <string>
#include <vector>

#include "pnsplat/engine/engine.h"

namespace pnsplat::tools {

// One line: the frame's fields (frame_ms is the wall time from its start to the next frame's;
// camera and fov_degrees as render's --camera and --fov take them; median_splat_px, max_splat_px and
// over_threshold are null unless FrameReport::splatsMeasured; the camera in the file's coordinates,
// `origin` + position, engine::cameraText).
std::string frameJson(const engine::FrameReport& report, double frameMs, glm::dvec3 origin = glm::dvec3(0.0));

// Frames of one run, summarised.
class FrameSeries {
  public:
    void add(const engine::FrameReport& report, double frameMs);
    // A frame's picture against the lockstep settled picture of its camera (bench view
    // --quality-every): PSNR (identical pictures count as kIdenticalPsnr) and SSIM.
    void addQuality(double psnr, double ssim);
    std::size_t size() const { return frames_.size(); }
    // median and 95th percentile frame time; points generated per second over the run and over the
    // frames that began with refinements queued; uploads per second; the per-frame split (medians);
    // the splats drawn per covered pixel (median, of the frames read back); the quality's median
    // and 5th percentile PSNR and median SSIM (null without quality frames); the largest splat and
    // share over the threshold (null when no frame measured its splats).
    std::string summaryJson(double seconds, const engine::EngineSettings& settings, const std::string& device,
                            const std::string& driver) const;

  private:
    struct Frame {
        engine::FrameReport report;
        double ms;
    };
    std::vector<Frame> frames_;
    std::vector<double> psnr_, ssim_;
};

// The PSNR that stands for identical pictures (infinite) in JSON.
inline constexpr double kIdenticalPsnr = 99.0;

// The median and the q-quantile (0..1, nearest rank) of `values` (0 when empty).
double median(std::vector<double> values);
double quantile(std::vector<double> values, double q);
// The processor's name from /proc/cpuinfo ("unknown" elsewhere), for JSON records.
std::string cpuName();

} // namespace pnsplat::tools
