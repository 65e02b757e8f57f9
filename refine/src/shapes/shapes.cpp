// Procedural models and exact analytic surfaces (see shapes.h). Not part of the paper: test and
// demo inputs, and the ground truth of `pnsplat eval` for spheres and tori.
//
// Everything is computed in double and rounded to float once, so positions lie on the surface
// to float precision and normals are exact to float precision.
#include "pnsplat/refine/shapes/shapes.h"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <complex>
#include <numbers>
#include <random>
#include <vector>

#include <glm/geometric.hpp>

namespace pnsplat {
namespace {

using DVec3 = glm::dvec3;

constexpr double kPi = std::numbers::pi;
constexpr double kTwoPi = 2.0 * std::numbers::pi;
// The golden angle pi (3 - sqrt 5): successive Fibonacci-spiral points turn by it.
constexpr double kGoldenAngle = std::numbers::pi * (3.0 - 2.23606797749978969640917366873128);
// 1 / golden ratio: fractional offsets of successive torus rings.
constexpr double kInverseGolden = 0.61803398874989484820458683436564;

// Uniform double in [0, 1) from the top 53 bits: the same on every standard library.
double uniform01(std::mt19937_64& rng) {
    return static_cast<double>(rng() >> 11) * 0x1.0p-53;
}

glm::vec3 toFloat(const DVec3& v) {
    return glm::vec3(v);
}

// Appends a point with position p and unit normal n, both computed in double.
void append(PointSet& set, const DVec3& p, const DVec3& n) {
    set.position.push_back(toFloat(p));
    set.normal.push_back(glm::normalize(toFloat(n)));
}

// Unit direction of Fibonacci-spiral point i of n (z from 1 - 1/n down to -1 + 1/n).
DVec3 fibonacciDirection(std::size_t i, std::size_t n) {
    const double z = 1.0 - (2.0 * static_cast<double>(i) + 1.0) / static_cast<double>(n);
    const double s = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double phi = kGoldenAngle * static_cast<double>(i);
    return glm::normalize(DVec3(s * std::cos(phi), s * std::sin(phi), z));
}

// n coloured points of a star-shaped surface, one in each direction of the Fibonacci sphere moved by
// up to 25 % of the mean spacing along each of two tangent axes (uniformly): nearest-neighbour
// distances vary by about 17 % (coefficient of variation; 3 % without jitter) while the closest
// pair keeps 45 % of the mean distance: irregular, but not pathological. `add(d, set)` appends the
// point of direction d with its normal and colour.
template <class Add>
PointSet sampleJittered(std::size_t n, std::uint64_t seed, Add add) {
    constexpr double kJitter = 0.25;
    const double spacing = std::sqrt(4.0 * kPi / static_cast<double>(std::max<std::size_t>(n, 1)));
    std::mt19937_64 rng(seed);
    PointSet set;
    set.position.reserve(n);
    set.normal.reserve(n);
    set.colour.reserve(n);
    for (std::size_t i = 0; i < n; ++i) {
        const DVec3 d0 = fibonacciDirection(i, n);
        const DVec3 helper = std::abs(d0.z) < 0.9 ? DVec3(0.0, 0.0, 1.0) : DVec3(1.0, 0.0, 0.0);
        const DVec3 e1 = glm::normalize(glm::cross(helper, d0));
        const DVec3 e2 = glm::cross(d0, e1);
        const double a = 2.0 * uniform01(rng) - 1.0;
        const double b = 2.0 * uniform01(rng) - 1.0;
        add(glm::normalize(d0 + kJitter * spacing * (a * e1 + b * e2)), set);
    }
    return set;
}

// Outward unit normal of the torus at parameters (u, v): also the direction from the tube
// circle to the point.
DVec3 torusNormal(double u, double v) {
    return DVec3(std::cos(v) * std::cos(u), std::cos(v) * std::sin(u), std::sin(v));
}

void appendTorusPoint(PointSet& set, double R, double r, double u, double v) {
    const DVec3 n = torusNormal(u, v);
    const DVec3 circle(R * std::cos(u), R * std::sin(u), 0.0);
    append(set, circle + r * n, n);
}

// ---- The bumpy sphere (the default model before issue 26): rho(d) = 1 + 0.25 f(d) over unit
// directions d. ----

constexpr double kBumpAmplitude = 0.25;
constexpr double kThreeSqrt3 = 5.19615242270663188058233902451762;

// f and the gradient of its polynomial extension to R^3, at the unit direction d.
// The four terms are bounded by 1 in magnitude on the unit sphere and the weights sum to 1.
struct Bump {
    double value;
    DVec3 gradient;
};

Bump bump(const DVec3& d) {
    const double x = d.x, y = d.y, z = d.z;
    // Zonal P2 about z: 1.5 z^2 - 0.5, in [-0.5, 1].
    const double t1 = 1.5 * z * z - 0.5;
    const DVec3 g1(0.0, 0.0, 3.0 * z);
    // Sectoral degree 3 about z: Re (x + iy)^3 = x^3 - 3 x y^2, in [-1, 1].
    const double t2 = x * x * x - 3.0 * x * y * y;
    const DVec3 g2(3.0 * x * x - 3.0 * y * y, -6.0 * x * y, 0.0);
    // Tesseral degree 3: 3 sqrt(3) x y z, in [-1, 1].
    const double t3 = kThreeSqrt3 * x * y * z;
    const DVec3 g3 = kThreeSqrt3 * DVec3(y * z, x * z, x * y);
    // Zonal P4 about y: (35 y^4 - 30 y^2 + 3) / 8, in [-0.43, 1].
    const double y2 = y * y;
    const double t4 = (35.0 * y2 * y2 - 30.0 * y2 + 3.0) / 8.0;
    const DVec3 g4(0.0, (140.0 * y2 * y - 60.0 * y) / 8.0, 0.0);

    constexpr double w1 = 0.35, w2 = 0.30, w3 = 0.20, w4 = 0.15;
    return {w1 * t1 + w2 * t2 + w3 * t3 + w4 * t4, w1 * g1 + w2 * g2 + w3 * g3 + w4 * g4};
}

// The surface point and its analytic outward normal. For x(d) = rho(d) d the implicit function
// F(x) = |x| - rho(x/|x|) has gradient d - grad_S(rho)/rho on the surface, where grad_S is the
// gradient along the unit sphere (the tangential part of the extension's gradient); hence
// n ~ rho d - grad_S(rho).
struct SurfacePoint {
    DVec3 position;
    DVec3 normal;
    double bump;
};

SurfacePoint bumpySpherePoint(const DVec3& d) {
    const Bump b = bump(d);
    const double rho = 1.0 + kBumpAmplitude * b.value;
    const DVec3 tangentialGradient = kBumpAmplitude * (b.gradient - glm::dot(b.gradient, d) * d);
    return {rho * d, glm::normalize(rho * d - tangentialGradient), b.value};
}

// HSV (hue in degrees, s and v in [0,1]) to 8-bit RGB.
glm::u8vec3 hsvToRgb(double hue, double s, double v) {
    const double h = std::fmod(hue, 360.0) / 60.0;
    const double c = v * s;
    const double x = c * (1.0 - std::abs(std::fmod(h, 2.0) - 1.0));
    DVec3 rgb;
    if (h < 1.0)
        rgb = {c, x, 0.0};
    else if (h < 2.0)
        rgb = {x, c, 0.0};
    else if (h < 3.0)
        rgb = {0.0, c, x};
    else if (h < 4.0)
        rgb = {0.0, x, c};
    else if (h < 5.0)
        rgb = {x, 0.0, c};
    else
        rgb = {c, 0.0, x};
    rgb += DVec3(v - c);
    auto to8 = [](double t) {
        return static_cast<std::uint8_t>(std::lround(std::clamp(t, 0.0, 1.0) * 255.0));
    };
    return {to8(rgb.x), to8(rgb.y), to8(rgb.z)};
}

} // namespace

PointSet sampleSphereUniform(std::size_t n, float radius) {
    assert(radius > 0.0f);
    PointSet set;
    set.position.reserve(n);
    set.normal.reserve(n);
    for (std::size_t i = 0; i < n; ++i) {
        const DVec3 d = fibonacciDirection(i, n);
        append(set, static_cast<double>(radius) * d, d);
    }
    return set;
}

PointSet sampleSphereRandom(std::size_t n, float radius, std::uint64_t seed) {
    assert(radius > 0.0f);
    std::mt19937_64 rng(seed);
    PointSet set;
    set.position.reserve(n);
    set.normal.reserve(n);
    for (std::size_t i = 0; i < n; ++i) {
        // Archimedes: z uniform in [-1, 1] and the azimuth uniform give a uniform sphere point.
        const double z = 2.0 * uniform01(rng) - 1.0;
        const double phi = kTwoPi * uniform01(rng);
        const double s = std::sqrt(std::max(0.0, 1.0 - z * z));
        const DVec3 d = glm::normalize(DVec3(s * std::cos(phi), s * std::sin(phi), z));
        append(set, static_cast<double>(radius) * d, d);
    }
    return set;
}

PointSet sampleTorusRandom(std::size_t n, float R, float r, std::uint64_t seed) {
    assert(R > r && r > 0.0f);
    const double dR = R, dr = r;
    std::mt19937_64 rng(seed);
    PointSet set;
    set.position.reserve(n);
    set.normal.reserve(n);
    for (std::size_t i = 0; i < n; ++i) {
        const double u = kTwoPi * uniform01(rng);
        // The area density in v is proportional to R + r cos v, at most R + r: rejection.
        double v = 0.0;
        do {
            v = kTwoPi * uniform01(rng);
        } while (uniform01(rng) * (dR + dr) > dR + dr * std::cos(v));
        appendTorusPoint(set, dR, dr, u, v);
    }
    return set;
}

PointSet sampleTorusUniform(std::size_t n, float R, float r) {
    assert(R > r && r > 0.0f);
    PointSet set;
    if (n == 0) return set;
    const double dR = R, dr = r;
    // Square-ish cells of area A/n, A = 4 pi^2 R r: the tube circumference 2 pi r holds
    // sqrt(n r / R) rings.
    const auto rings = static_cast<std::size_t>(
        std::clamp(std::round(std::sqrt(static_cast<double>(n) * dr / dR)), 1.0, static_cast<double>(n)));
    const double dv = kTwoPi / static_cast<double>(rings);

    // Ring j covers v in [j dv, (j+1) dv]; its band has area r * 2 pi * (R dv + 2 r cos(v_j)
    // sin(dv/2)) with v_j the band's middle. Counts follow the band areas (largest remainder).
    std::vector<double> share(rings);
    double total = 0.0;
    for (std::size_t j = 0; j < rings; ++j) {
        const double vj = (static_cast<double>(j) + 0.5) * dv;
        share[j] = dR * dv + 2.0 * dr * std::cos(vj) * std::sin(0.5 * dv);
        total += share[j];
    }
    std::vector<std::size_t> count(rings);
    std::vector<std::pair<double, std::size_t>> remainder(rings);
    std::size_t assigned = 0;
    for (std::size_t j = 0; j < rings; ++j) {
        const double exact = static_cast<double>(n) * share[j] / total;
        count[j] = static_cast<std::size_t>(std::floor(exact));
        assigned += count[j];
        remainder[j] = {exact - std::floor(exact), j};
    }
    std::sort(remainder.begin(), remainder.end(), [](const auto& a, const auto& b) {
        return a.first > b.first || (a.first == b.first && a.second < b.second);
    });
    for (std::size_t k = 0; assigned < n; ++k, ++assigned) ++count[remainder[k % rings].second];

    set.position.reserve(n);
    set.normal.reserve(n);
    for (std::size_t j = 0; j < rings; ++j) {
        const double v = (static_cast<double>(j) + 0.5) * dv;
        const double offset = std::fmod(static_cast<double>(j) * kInverseGolden, 1.0);
        for (std::size_t i = 0; i < count[j]; ++i) {
            const double u = kTwoPi * (static_cast<double>(i) + offset) / static_cast<double>(count[j]);
            appendTorusPoint(set, dR, dr, u, v);
        }
    }
    assert(set.size() == n);
    return set;
}

PointSet farApartTriangles(std::size_t count) {
    PointSet triangles;
    for (std::size_t c = 0; c < count; ++c) {
        const glm::vec3 corner(1e20f * float(c), 0.0f, 0.0f);
        for (const glm::vec3 e :
             {glm::vec3(0.0f), glm::vec3(0.0f, 1.0f, 0.0f), glm::vec3(0.0f, 0.5f, 0.866f)}) {
            triangles.position.push_back(corner + 1e14f * e);
            triangles.normal.emplace_back(1.0f, 0.0f, 0.0f);
        }
    }
    return triangles;
}

PointSet sampleCappedCylinder(std::size_t rimPoints, float R, float H) {
    assert(rimPoints >= 3 && R > 0.0f && H > 0.0f);
    const double dR = R, dH = H, half = 0.5 * dH;
    const double spacing = kTwoPi * dR / static_cast<double>(rimPoints);
    PointSet set;
    set.crease.reserve(rimPoints); // marks the set as one with crease normals
    const auto append = [&](glm::dvec3 position, glm::dvec3 normal, glm::dvec3 crease) {
        set.position.push_back(glm::vec3(position));
        set.normal.push_back(glm::vec3(normal));
        set.crease.push_back(glm::vec3(crease));
    };
    // Side rings strictly between the rims; every ring turned by half a step against the last.
    const auto sideRings = static_cast<std::size_t>(std::max(1.0, std::round(dH / spacing)));
    for (std::size_t j = 0; j <= sideRings; ++j) {
        const double z = -half + dH * static_cast<double>(j) / static_cast<double>(sideRings);
        for (std::size_t i = 0; i < rimPoints; ++i) {
            const double u = kTwoPi * (static_cast<double>(i) + 0.5 * static_cast<double>(j % 2)) /
                             static_cast<double>(rimPoints);
            const glm::dvec3 radial(std::cos(u), std::sin(u), 0.0);
            const bool rim = j == 0 || j == sideRings;
            append(glm::dvec3(dR * radial.x, dR * radial.y, z), radial,
                   rim ? glm::dvec3(0.0, 0.0, z > 0.0 ? 1.0 : -1.0) : glm::dvec3(0.0));
        }
    }
    // Caps: concentric rings inside the rim, a point at the centre.
    const auto capRings = static_cast<std::size_t>(std::max(1.0, std::round(dR / spacing)));
    for (const double z : {-half, half}) {
        const glm::dvec3 up(0.0, 0.0, z > 0.0 ? 1.0 : -1.0);
        append(glm::dvec3(0.0, 0.0, z), up, glm::dvec3(0.0));
        for (std::size_t k = 1; k < capRings; ++k) {
            const double rho = dR * static_cast<double>(k) / static_cast<double>(capRings);
            const auto count = static_cast<std::size_t>(std::max(3.0, std::round(kTwoPi * rho / spacing)));
            const double offset = std::fmod(static_cast<double>(k) * kInverseGolden, 1.0);
            for (std::size_t i = 0; i < count; ++i) {
                const double u = kTwoPi * (static_cast<double>(i) + offset) / static_cast<double>(count);
                append(glm::dvec3(rho * std::cos(u), rho * std::sin(u), z), up, glm::dvec3(0.0));
            }
        }
    }
    return set;
}

double terrainHeight(double x, double y) {
    return 0.5 * std::sin(0.3 * x) * std::cos(0.2 * y);
}

PointSet sampleTerrainScan(std::size_t n, double nearest, double farthest, std::uint64_t seed) {
    assert(nearest > 0.0 && nearest < farthest);
    std::mt19937_64 rng(seed);
    PointSet set;
    set.position.reserve(n);
    set.normal.reserve(n);
    const double logNearest = std::log(nearest), logSpan = std::log(farthest) - logNearest;
    for (std::size_t i = 0; i < n; ++i) {
        const double range = std::exp(logNearest + logSpan * uniform01(rng));
        const double angle = kTwoPi * uniform01(rng);
        const double x = range * std::cos(angle), y = range * std::sin(angle);
        // The gradient of the height: the normal is (-dz/dx, -dz/dy, 1), normalised.
        const double dx = 0.15 * std::cos(0.3 * x) * std::cos(0.2 * y);
        const double dy = -0.1 * std::sin(0.3 * x) * std::sin(0.2 * y);
        append(set, DVec3(x, y, terrainHeight(x, y)), glm::normalize(DVec3(-dx, -dy, 1.0)));
    }
    return set;
}

PointSet makeBumpySphere() {
    return sampleJittered(2000, 0x5EED2005u, [](DVec3 d, PointSet& set) {
        const SurfacePoint s = bumpySpherePoint(d);
        append(set, s.position, s.normal);
        // Hue from the bump value: valleys (f = -1) blue, crests (f = 1) red.
        const double hue = 240.0 * (1.0 - 0.5 * (std::clamp(s.bump, -1.0, 1.0) + 1.0));
        set.colour.push_back(hsvToRgb(hue, 0.7, 0.95));
    });
}

glm::vec3 bumpySphereSurface(glm::vec3 direction) {
    const DVec3 d(direction);
    assert(glm::dot(d, d) > 0.0);
    return toFloat(bumpySpherePoint(glm::normalize(d)).position);
}

// ---- The default model (issue 26): a ridged, horned, coloured star-shaped surface ----
//
// rho(d) = 1 + body(d) + ridges(d) + sum of horns(d) over unit directions d (see shapes.h); the
// normal follows from the gradient of each term's extension to R^3 as for the bumpy sphere.

namespace {

constexpr int kRidges = 12; // ridges around the y axis
constexpr double kRidgeAmplitude = 0.06;
constexpr double kBodyAmplitude = 0.12; // elongation along y

// A horn: height * exp((d . axis - 1) / width): about width^(1/2) radians wide at its base.
struct Horn {
    DVec3 axis;
    double height, width;
};

std::array<Horn, 4> horns() {
    return {{{glm::normalize(DVec3(0.25, 1.0, 0.2)), 0.75, 0.02},
             {glm::normalize(DVec3(-1.0, -0.35, 0.45)), 0.6, 0.025},
             {glm::normalize(DVec3(0.9, -0.55, 0.5)), 0.6, 0.025},
             {glm::normalize(DVec3(0.1, -0.3, -1.0)), 0.5, 0.03}}};
}

struct DefaultField {
    double value;      // rho - 1
    DVec3 gradient;    // of the extension to R^3
    double band;       // s^k, s the distance from the y axis: where the ridges are (0..1)
    double ridgePhase; // cos(k phi) about the y axis: 1 on a crest, -1 in a valley
    double horn;       // how much of a horn's foot the direction lies in (0..1)
};

DefaultField defaultField(const DVec3& d) {
    const double x = d.x, y = d.y, z = d.z;
    // Body: 1.5 y^2 - 0.5 (zonal P2 about y), elongated along y.
    double value = kBodyAmplitude * (1.5 * y * y - 0.5);
    DVec3 gradient(0.0, kBodyAmplitude * 3.0 * y, 0.0);
    // Ridges: Re (z + i x)^k = s^k cos(k phi), a polynomial: smooth at the poles, where it vanishes.
    const std::complex<double> w(z, x);
    std::complex<double> wk1(1.0, 0.0); // w^(k-1)
    for (int i = 1; i < kRidges; ++i) wk1 *= w;
    const std::complex<double> wk = wk1 * w;
    value += kRidgeAmplitude * wk.real();
    // d/dz Re w^k = k Re w^(k-1); d/dx Re w^k = Re(i k w^(k-1)) = -k Im w^(k-1).
    gradient += kRidgeAmplitude * double(kRidges) * DVec3(-wk1.imag(), 0.0, wk1.real());
    const double band = std::abs(wk);
    const double phase = band > 1e-12 ? wk.real() / band : 0.0;
    double horn = 0.0;
    for (const Horn& h : horns()) {
        const double cosine = glm::dot(d, h.axis);
        const double t = h.height * std::exp((cosine - 1.0) / h.width);
        value += t;
        gradient += (t / h.width) * h.axis;
        horn = std::max(horn, std::exp((cosine - 1.0) / (3.0 * h.width)));
    }
    return {value, gradient, band, phase, horn};
}

// x(d) = rho(d) d and its outward normal rho d - grad_S(rho) (see bumpySpherePoint).
SurfacePoint defaultModelPoint(const DVec3& d, DefaultField& field) {
    field = defaultField(d);
    const double rho = 1.0 + field.value;
    const DVec3 tangentialGradient = field.gradient - glm::dot(field.gradient, d) * d;
    return {rho * d, glm::normalize(rho * d - tangentialGradient), field.value};
}

DVec3 mix(const DVec3& a, const DVec3& b, double t) {
    return a + (b - a) * std::clamp(t, 0.0, 1.0);
}

// Three colours: a blue-green body, an orange band whose crests are lighter, red horns.
glm::u8vec3 defaultModelColour(const DefaultField& f) {
    const DVec3 body(0.20, 0.55, 0.75), valley(0.85, 0.40, 0.10), crest(0.98, 0.85, 0.35),
        horn(0.85, 0.12, 0.20);
    DVec3 c = mix(body, mix(valley, crest, 0.5 + 0.5 * f.ridgePhase), f.band);
    c = mix(c, horn, f.horn);
    return {static_cast<std::uint8_t>(std::lround(c.x * 255.0)),
            static_cast<std::uint8_t>(std::lround(c.y * 255.0)),
            static_cast<std::uint8_t>(std::lround(c.z * 255.0))};
}

} // namespace

PointSet sampleDefaultModel(std::size_t n, std::uint64_t seed) {
    return sampleJittered(n, seed, [](DVec3 d, PointSet& set) {
        DefaultField field{};
        const SurfacePoint s = defaultModelPoint(d, field);
        append(set, s.position, s.normal);
        set.colour.push_back(defaultModelColour(field));
    });
}

PointSet makeDefaultModel() {
    return sampleDefaultModel(kDefaultModelPoints, kDefaultModelSeed);
}

glm::vec3 defaultModelSurface(glm::vec3 direction) {
    const DVec3 d(direction);
    assert(glm::dot(d, d) > 0.0);
    DefaultField field{};
    return toFloat(defaultModelPoint(glm::normalize(d), field).position);
}

// ---- AnalyticSurface ----

namespace {

// For the torus: the unit radial direction (in the z = 0 plane) of q, +x on the axis.
DVec3 radialDirection(const DVec3& q) {
    const double rho = std::sqrt(q.x * q.x + q.y * q.y);
    return rho > 0.0 ? DVec3(q.x / rho, q.y / rho, 0.0) : DVec3(1.0, 0.0, 0.0);
}

// Closest point's direction from the sphere centre or the nearest tube-circle point ("spine"),
// and that spine point, both relative to the surface centre.
struct Spine {
    DVec3 point;   // centre of the sphere, or nearest point of the torus tube circle
    DVec3 offset;  // q - point
    double length; // |offset|
};

Spine spine(const AnalyticSurface& s, glm::vec3 p) {
    const DVec3 q = DVec3(p) - DVec3(s.centre);
    DVec3 point(0.0);
    if (s.kind == AnalyticSurface::Kind::Torus) point = static_cast<double>(s.R) * radialDirection(q);
    const DVec3 offset = q - point;
    return {point, offset, glm::length(offset)};
}

double spineRadius(const AnalyticSurface& s) {
    return s.kind == AnalyticSurface::Kind::Sphere ? static_cast<double>(s.R) : static_cast<double>(s.r);
}

DVec3 spineNormal(const AnalyticSurface& s, const Spine& sp, const DVec3& q) {
    if (sp.length > 0.0) return sp.offset / sp.length;
    // Degenerate: at the sphere's centre take +z; on the tube circle take the outer radial side.
    return s.kind == AnalyticSurface::Kind::Sphere ? DVec3(0.0, 0.0, 1.0) : radialDirection(q);
}

} // namespace

glm::vec3 AnalyticSurface::closestPoint(glm::vec3 p) const {
    const Spine sp = spine(*this, p);
    const DVec3 q = DVec3(p) - DVec3(centre);
    return toFloat(DVec3(centre) + sp.point + spineRadius(*this) * spineNormal(*this, sp, q));
}

float AnalyticSurface::distance(glm::vec3 p) const {
    return static_cast<float>(std::abs(spine(*this, p).length - spineRadius(*this)));
}

float AnalyticSurface::signedDistance(glm::vec3 p) const {
    return static_cast<float>(spine(*this, p).length - spineRadius(*this));
}

glm::vec3 AnalyticSurface::normalAt(glm::vec3 p) const {
    const Spine sp = spine(*this, p);
    const DVec3 q = DVec3(p) - DVec3(centre);
    return toFloat(spineNormal(*this, sp, q));
}

float AnalyticSurface::boundingDiagonal() const {
    const double dR = R, dr = r;
    if (kind == Kind::Sphere) return static_cast<float>(2.0 * dR * std::sqrt(3.0));
    const double w = 2.0 * (dR + dr), h = 2.0 * dr;
    return static_cast<float>(std::sqrt(2.0 * w * w + h * h));
}

double AnalyticSurface::area() const {
    const double dR = R, dr = r;
    return kind == Kind::Sphere ? 4.0 * kPi * dR * dR : 4.0 * kPi * kPi * dR * dr;
}

} // namespace pnsplat
