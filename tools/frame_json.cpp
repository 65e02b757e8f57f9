#include "frame_json.h"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <fstream>
#include <glm/trigonometric.hpp>

namespace pnsplat::tools {

double quantile(std::vector<double> values, double q) {
    if (values.empty()) return 0.0;
    std::sort(values.begin(), values.end());
    const auto rank = static_cast<std::size_t>(std::ceil(q * double(values.size())));
    return values[std::min(values.size() - 1, rank > 0 ? rank - 1 : 0)];
}

double median(std::vector<double> values) {
    if (values.empty()) return 0.0;
    std::sort(values.begin(), values.end());
    return values[values.size() / 2];
}

std::string cpuName() {
    std::ifstream in("/proc/cpuinfo");
    std::string line;
    while (std::getline(in, line)) {
        if (line.rfind("model name", 0) != 0) continue;
        const std::size_t colon = line.find(':');
        if (colon != std::string::npos && colon + 2 <= line.size()) return line.substr(colon + 2);
    }
    return "unknown";
}

namespace {
// A figure in JSON: null when it is not `known`.
std::string nullUnless(bool known, const std::string& figure) {
    return known ? figure : "null";
}
// A figure of `values`: null when there are none.
std::string orNull(const std::vector<double>& values, double figure) {
    return nullUnless(!values.empty(), fmt::format("{:.4g}", figure));
}
// `amount` a second over `seconds`: 0 when no time passed.
double perSecond(double amount, double seconds) {
    return seconds > 0 ? amount / seconds : 0.0;
}
} // namespace

std::string frameJson(const engine::FrameReport& r, double frameMs, glm::dvec3 origin) {
    return fmt::format(
        R"({{"frame": {}, "frame_ms": {:.2f}, "cpu_ms": {:.2f}, "selection_ms": {:.2f}, "upload_ms": {:.2f}, )"
        R"("refine_wait_ms": {:.2f}, "gpu_wait_ms": {:.2f}, "refine_ms": {:.2f}, "visibility_ms": {:.2f}, "accumulation_ms": {:.2f}, "normalization_ms": {:.2f}, )"
        R"("splats_drawn": {}, "covered_px": {}, "splats_per_covered_px": {}, "nodes_visible": {}, )"
        R"("nodes_refined": {}, "points_generated": {}, )"
        R"("nodes_uploaded": {}, "bytes_uploaded": {}, "cache_bytes_used": {}, "evictions": {}, "queue_length": {}, )"
        R"("refine_busy_ms": {:.2f}, "refine_cpu_ms": {:.2f}, "tree_nodes": {}, "tree_points": {}, "threshold_px": {:.3f}, "median_splat_px": {}, "max_splat_px": {}, )"
        R"("over_threshold": {}, )"
        R"("resting": {}, "settled": {}, "camera": "{}", "fov_degrees": {:.6g}}})",
        r.frame, frameMs, r.cpuMs, r.selectionMs, r.uploadMs, r.refineWaitMs, r.gpuWaitMs, r.refineMs,
        r.gpu.visibilityMs, r.gpu.accumulationMs, r.gpu.normalizationMs, r.splatsDrawn, r.coveredPixels,
        nullUnless(r.coveredPixels > 0,
                   fmt::format("{:.3f}", double(r.splatsDrawn) / double(r.coveredPixels))),
        r.nodesVisible, r.nodesRefined, r.pointsGenerated, r.nodesUploaded, r.bytesUploaded, r.cacheBytesUsed,
        r.evictions, r.queueLength, r.refineBusyMs, r.refineCpuMs, r.treeNodes, r.treePoints, r.thresholdPx,
        nullUnless(r.splatsMeasured, fmt::format("{:.3f}", r.medianSplatPx)),
        nullUnless(r.splatsMeasured, fmt::format("{:.3f}", r.maxSplatPx)),
        nullUnless(r.splatsMeasured, fmt::format("{:.5f}", r.overThreshold)), r.resting ? "true" : "false",
        r.settled ? "true" : "false", engine::cameraText(r.camera, origin), glm::degrees(r.camera.fovY));
}

void FrameSeries::add(const engine::FrameReport& report, double frameMs) {
    frames_.push_back({report, frameMs});
}

void FrameSeries::addQuality(double psnr, double ssim) {
    psnr_.push_back(std::min(psnr, kIdenticalPsnr));
    ssim_.push_back(ssim);
}

std::string FrameSeries::summaryJson(double seconds, const engine::EngineSettings& settings,
                                     const std::string& device, const std::string& driver) const {
    std::vector<double> ms, selection, upload, visibility, accumulation, normalization, splats, perCovered;
    std::size_t generated = 0, uploads = 0, uploadBytes = 0, evictions = 0;
    double busyMs = 0.0, cpuMs = 0.0, worstOver = 0.0;
    float largest = 0.0f;
    bool measuredAny = false;
    for (std::size_t k = 0; k < frames_.size(); ++k) {
        const engine::FrameReport& r = frames_[k].report;
        ms.push_back(frames_[k].ms);
        selection.push_back(r.selectionMs);
        upload.push_back(r.uploadMs);
        visibility.push_back(r.gpu.visibilityMs);
        accumulation.push_back(r.gpu.accumulationMs);
        normalization.push_back(r.gpu.normalizationMs);
        splats.push_back(double(r.splatsDrawn));
        if (r.coveredPixels > 0) perCovered.push_back(double(r.splatsDrawn) / double(r.coveredPixels));
        generated += r.pointsGenerated;
        uploads += r.nodesUploaded;
        uploadBytes += r.bytesUploaded;
        evictions += r.evictions;
        measuredAny |= r.splatsMeasured;
        largest = std::max(largest, r.maxSplatPx);
        worstOver = std::max(worstOver, r.overThreshold);
        // The time during which refinement jobs were waiting or running, and the processor time of
        // the jobs that finished; what they made joins the tree a frame later (the jobs still
        // running after the last frame add busy time but no points; the last frame's finished jobs,
        // processor time but no points).
        busyMs += r.refineBusyMs;
        cpuMs += r.refineCpuMs;
    }
    return fmt::format(
        R"({{"summary": true, "frames": {}, "seconds": {:.3f}, "frame_ms_median": {:.2f}, "frame_ms_p95": {:.2f}, )"
        R"("fps_median": {:.1f}, "points_generated": {}, "points_per_second": {:.0f}, )"
        R"("points_per_second_while_queued": {:.0f}, "queued_seconds": {:.3f}, )"
        R"("points_per_cpu_second": {:.0f}, "refine_cpu_seconds": {:.3f}, "uploads_per_second": {:.1f}, )"
        R"("upload_mb_per_second": {:.2f}, "evictions": {}, "splats_drawn_median": {:.0f}, )"
        R"("splats_per_covered_px_median": {}, "quality_frames": {}, "psnr_median": {}, "psnr_p5": {}, )"
        R"("ssim_median": {}, )"
        R"("selection_ms_median": {:.2f}, "upload_ms_median": {:.2f}, "visibility_ms_median": {:.2f}, )"
        R"("accumulation_ms_median": {:.2f}, "normalization_ms_median": {:.2f}, "max_splat_px_max": {}, )"
        R"("over_threshold_max": {}, "threshold_px": {}, "cache_mb": {:.1f}, "workers": {}, "width": {}, )"
        R"("height": {}, "smooth_edges": {}, "fill_pinholes": {}, "path": "{}", "device": "{}", "driver": "{}", "cpu": "{}"}})",
        frames_.size(), seconds, median(ms), quantile(ms, 0.95), median(ms) > 0 ? 1000.0 / median(ms) : 0.0,
        generated, perSecond(double(generated), seconds), perSecond(double(generated), busyMs * 1e-3),
        busyMs * 1e-3, perSecond(double(generated), cpuMs * 1e-3), cpuMs * 1e-3,
        perSecond(double(uploads), seconds), perSecond(double(uploadBytes) / double(1 << 20), seconds),
        evictions, median(splats), orNull(perCovered, median(perCovered)), psnr_.size(),
        orNull(psnr_, median(psnr_)), orNull(psnr_, quantile(psnr_, 0.05)), orNull(ssim_, median(ssim_)),
        median(selection), median(upload), median(visibility), median(accumulation), median(normalization),
        nullUnless(measuredAny, fmt::format("{:.3f}", largest)),
        nullUnless(measuredAny, fmt::format("{:.5f}", worstOver)), settings.threshold,
        double(settings.cacheBytes) / double(1 << 20), settings.workers, settings.render.width,
        settings.render.height, settings.render.smoothEdges ? "true" : "false",
        settings.render.fillPinholes ? "true" : "false",
        settings.render.path == engine::RenderPath::Compute ? "compute" : "graphics", device, driver,
        cpuName());
}

} // namespace pnsplat::tools
