// PCL's moving least squares upsampling for `bench refine` (bench_pcl.h; PNSPLAT_WITH_PCL only).
#include "bench_pcl.h"

#include <algorithm>
#include <cassert>
#include <chrono>
#include <cmath>
#include <vector>

#include <fmt/core.h>
#include <glm/geometric.hpp>
#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/pcl_config.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>
#include <pcl/surface/mls.h>

namespace pnsplat::tools {

namespace {

using Mls = pcl::MovingLeastSquares<pcl::PointXYZ, pcl::PointNormal>;

// The spacing the radii follow: the upsampling disc reaches the median distance to the 6th nearest
// other point (about the one-ring pnsplat builds its triangles from, so that the discs of
// neighbouring points cover the surface between them), the fit twice as far (about 24 points of
// a uniform sample, enough for a quadric's 6 coefficients where the sampling is random and thin).
constexpr int kUpsamplingNeighbour = 6;
constexpr double kSearchOverUpsampling = 2.0;

pcl::PointCloud<pcl::PointXYZ>::Ptr toPcl(const PointSet& input) {
    auto cloud = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
    cloud->reserve(input.size());
    for (const glm::vec3& p : input.position) cloud->push_back(pcl::PointXYZ(p.x, p.y, p.z));
    return cloud;
}

double medianNeighbourDistance(const pcl::PointCloud<pcl::PointXYZ>::Ptr& cloud, int k) {
    pcl::KdTreeFLANN<pcl::PointXYZ> tree;
    tree.setInputCloud(cloud);
    std::vector<int> indices;
    std::vector<float> squared;
    std::vector<double> distances;
    distances.reserve(cloud->size());
    for (const pcl::PointXYZ& p : *cloud) {
        const int found = tree.nearestKSearch(p, k + 1, indices, squared); // the point itself first
        if (found > 0) distances.push_back(std::sqrt(static_cast<double>(squared[found - 1])));
    }
    assert(!distances.empty());
    auto middle = distances.begin() + static_cast<std::ptrdiff_t>(distances.size() / 2);
    std::nth_element(distances.begin(), middle, distances.end());
    return *middle;
}

struct Upsampled {
    pcl::PointCloud<pcl::PointNormal> cloud;
    std::vector<int> sources; // the input point each output point was sampled around
    double seconds = 0.0;
};

Upsampled upsample(const pcl::PointCloud<pcl::PointXYZ>::Ptr& cloud, const PclMlsSettings& settings,
                   unsigned threads) {
    Mls mls;
    mls.setInputCloud(cloud);
    mls.setSearchMethod(pcl::make_shared<pcl::search::KdTree<pcl::PointXYZ>>());
    mls.setSearchRadius(settings.searchRadius);
    mls.setPolynomialOrder(settings.polynomialOrder);
    mls.setComputeNormals(true);
    mls.setUpsamplingMethod(Mls::SAMPLE_LOCAL_PLANE);
    mls.setUpsamplingRadius(settings.upsamplingRadius);
    mls.setUpsamplingStepSize(settings.step);
    mls.setNumberOfThreads(threads);
    Upsampled result;
    const auto start = std::chrono::steady_clock::now();
    mls.process(result.cloud);
    result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (const pcl::PointIndicesPtr sources = mls.getCorrespondingIndices()) result.sources = sources->indices;
    return result;
}

} // namespace

PclMlsSettings choosePclMlsSettings(const PointSet& input, std::size_t target, unsigned threads) {
    assert(input.size() >= 3 && target > 0);
    const auto cloud = toPcl(input);
    PclMlsSettings settings;
    settings.upsamplingRadius = medianNeighbourDistance(
        cloud, std::min<int>(kUpsamplingNeighbour, static_cast<int>(input.size()) - 1));
    settings.searchRadius = kSearchOverUpsampling * settings.upsamplingRadius;
    // The samples of a disc of radius r on a grid of step s are about pi (r / s)^2: a first guess,
    // then bisection on log(step) (the count falls as the step grows, in jumps as grid points leave
    // the disc), keeping the step whose count comes nearest the target.
    const double perPoint = static_cast<double>(target) / static_cast<double>(input.size());
    const double guess = settings.upsamplingRadius * std::sqrt(3.14159265358979 / perPoint);
    double low = guess / 2.0, high = guess * 2.0;
    double best = guess;
    double bestError = -1.0;
    for (int iteration = 0; iteration < 14; ++iteration) {
        const double step = std::sqrt(low * high);
        settings.step = step;
        const std::size_t count = upsample(cloud, settings, threads).cloud.size();
        const double error = std::abs(static_cast<double>(count) - static_cast<double>(target));
        if (bestError < 0.0 || error < bestError) {
            bestError = error;
            best = step;
        }
        if (count == target) break;
        (count > target ? low : high) = step;
    }
    settings.step = best;
    return settings;
}

PclMlsRun runPclMls(const PointSet& input, const PclMlsSettings& settings, unsigned threads) {
    const auto cloud = toPcl(input);
    Upsampled upsampled = upsample(cloud, settings, threads);
    PclMlsRun run;
    run.seconds = upsampled.seconds;
    const std::size_t n = upsampled.cloud.size();
    run.output.position.resize(n);
    run.output.normal.resize(n);
    const bool orient = input.hasNormal() && upsampled.sources.size() == n;
    for (std::size_t i = 0; i < n; ++i) {
        const pcl::PointNormal& p = upsampled.cloud[i];
        glm::vec3 normal(p.normal_x, p.normal_y, p.normal_z);
        // PCL orients a fit's normal as its plane's eigenvector falls; turned here (not timed) to the
        // side of the input normal of the point the sample came from, for rendering and eval.
        if (orient) {
            const auto source = static_cast<std::size_t>(upsampled.sources[i]);
            if (source < input.size() && glm::dot(normal, input.normal[source]) < 0.0f) normal = -normal;
        }
        run.output.position[i] = glm::vec3(p.x, p.y, p.z);
        run.output.normal[i] = normal;
    }
    return run;
}

std::string describePclMls(const PclMlsSettings& settings) {
    return fmt::format(
        "PCL " PCL_VERSION_PRETTY
        " pcl::MovingLeastSquares<PointXYZ, PointNormal>, SAMPLE_LOCAL_PLANE, polynomial order {}, "
        "search radius {:.6g}, upsampling radius {:.6g}, step {:.6g}, normals computed",
        settings.polynomialOrder, settings.searchRadius, settings.upsamplingRadius, settings.step);
}

} // namespace pnsplat::tools
