// `pnsplat diff`: compare two images (PSNR, SSIM, RMSE, share of differing pixels), optionally
// write a heat map, and fail past a threshold.
#include <cmath>
#include <string>

#include <fmt/core.h>

#include "commands.h"
#include "pnsplat/engine/image.h"

namespace pnsplat::tools {

namespace {

struct DiffArgs {
    std::string a, b;
    std::string heatmap;
    double maxRmse = -1.0;
    int pixelThreshold = 2;
    bool force = false;
};

void runDiff(const DiffArgs& args) {
    refuseToOverwriteInput(args.heatmap, {args.a, args.b}, args.force);
    const engine::RgbaImage a = unwrap(engine::readPng(args.a));
    const engine::RgbaImage b = unwrap(engine::readPng(args.b));
    const engine::ImageDifference d = unwrap(engine::compareImages(a, b, args.pixelThreshold));
    if (!args.heatmap.empty()) unwrap(engine::writePng(args.heatmap, d.heatmap));
    // JSON has no infinity: identical images report "psnr": null.
    const std::string psnr = std::isfinite(d.psnr) ? fmt::format("{:.3f}", d.psnr) : "null";
    fmt::print(
        "{{\"psnr\": {}, \"ssim\": {:.5f}, \"rmse\": {:.4f}, \"differing_share\": {:.6f}, \"width\": {}, "
        "\"height\": {}}}\n",
        psnr, d.ssim, d.rmse, d.differingShare, a.width, a.height);
    if (args.maxRmse >= 0.0 && d.rmse > args.maxRmse)
        throw CommandError(fmt::format("images differ: RMSE {:.4f} exceeds {:.4f}", d.rmse, args.maxRmse),
                           kExitDiffers);
}

} // namespace

void addDiffCommand(CLI::App& app) {
    const auto [cmd, args] =
        addSubcommand(app, "diff", "Compare two images: PSNR, SSIM, RMSE, differing pixels (JSON)", runDiff);
    cmd->add_option("A.png", args->a, "first PNG")->required();
    cmd->add_option("B.png", args->b, "second PNG")->required();
    cmd->add_option("--heatmap", args->heatmap, "write the per-pixel difference as a heat map PNG");
    addForceFlag(*cmd, args->force);
    cmd->add_option("--max-rmse", args->maxRmse,
                    "exit with status 1 when RMSE (0..255 units) exceeds this (errors: 2 or 3)")
        ->check(kNonNegative);
    cmd->add_option("--pixel-threshold", args->pixelThreshold,
                    "a pixel differs when a channel differs by more than this (0..255)")
        ->check(CLI::Range(0, 255))
        ->capture_default_str();
}

} // namespace pnsplat::tools
