// cone_embree: refl's glossy cone tracing (refl_hiz_* + refl_cone_*, seed
// 004 Sec. 4.4.5) through the C ABI against an Embree 3 Monte-Carlo glossy
// reference on the same pixels, one thread each.
//
// Scene (built here): a room with a glossy floor (roughness 0.35, Phong
// power 2 / r^4 - 2), three checkered walls, a box and a sphere; no
// ceiling, so upward rays see the environment. Shading is the one-bounce
// rule of src/shade.rs without shadows: a reflected ray shows the direct
// (ambient + Lambert) color of the surface it hits, or the environment.
//
//  * Reference: per floor pixel, N directions of the Phong lobe around the
//    mirror direction (inverse CDF cos t = xi^(1/(n+1)), Hammersley points
//    under a per-pixel rotation), below-surface samples rejected, each
//    traced with rtcIntersect1. Converged: 1024 samples, checked against
//    512 (their mean difference / sqrt(3), the 1024-sample estimate's own
//    noise, must stay under 1/255).
//  * refl: Embree renders the primary view (linear depth, direct color);
//    refl builds the Hi-Z (reversed-Z, infinite far), the color and
//    visibility pyramids, traces each floor pixel's mirror ray with
//    refl_hiz_trace_ray and cone-traces from the hit (refl_cone_trace,
//    normalized, 4 / 8 / 16 circles); a miss takes the environment.
//
// Printed: error (mean absolute difference of 8-bit sRGB reflection colors
// over the floor pixels) and time per method; the reference time at the
// cone's error (log-log interpolation between the reference rows, time ~
// error^-2 beyond them) over the cone's time. Checks are correctness only:
// every status OK, no NaN, the cone beats the environment alone, the
// converged reference is converged. Never time.
#include <embree3/rtcore.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <vector>

#include "check.hpp"
#include "refl.h"
#include "scene.hpp"

namespace {

using scene::V3;
using Clock = std::chrono::steady_clock;

#ifdef REFL_SANITIZE
constexpr uint32_t kW = 96, kH = 72;
#else
constexpr uint32_t kW = 256, kH = 192;
#endif
constexpr uint32_t kTruth = 1024;
constexpr double kRoughness = 0.35;
constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr double kPi = 3.14159265358979323846;

V3 normalize(V3 a) { return (1.0 / scene::length(a)) * a; }
V3 cross(V3 a, V3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
refl_vec3 rv(V3 v) { return {float(v.x), float(v.y), float(v.z)}; }

uint32_t hash32(uint32_t x) {
    x ^= x >> 16;
    x *= 0x7feb352du;
    x ^= x >> 15;
    x *= 0x846ca68bu;
    x ^= x >> 16;
    return x;
}

// Geometry ids: 0 floor, 1..3 walls, 4 box, 5 sphere.
struct Room {
    std::vector<scene::Mesh> meshes;
    Room() {
        const double s = 6.0, h = 3.5;
        meshes.push_back(scene::quad({-s, 0, s}, {s, 0, s}, {s, 0, -s}, {-s, 0, -s}));
        meshes.push_back(scene::quad({-s, 0, -s}, {s, 0, -s}, {s, h, -s}, {-s, h, -s}));
        meshes.push_back(scene::quad({-s, 0, s}, {-s, 0, -s}, {-s, h, -s}, {-s, h, s}));
        meshes.push_back(scene::quad({s, 0, -s}, {s, 0, s}, {s, h, s}, {s, h, -s}));
        meshes.push_back(scene::box({0.8, 0.6, -1.5}, {0.5, 0.6, 0.5}, 0.5));
        meshes.push_back(scene::sphere({-1.5, 0.8, -2.5}, 0.8, 24, 48));
    }
};

V3 env(V3 d) {
    d = normalize(d);
    const double e = std::max(0.0, d.y);
    return {0.75 + (0.12 - 0.75) * std::sqrt(e), 0.84 + (0.3 - 0.84) * std::sqrt(e), 0.95 + (0.72 - 0.95) * std::sqrt(e)};
}

V3 albedo(unsigned geom, V3 p) {
    const bool odd = (static_cast<long>(std::floor(p.x * 2)) + static_cast<long>(std::floor(p.y * 2)) +
                      static_cast<long>(std::floor(p.z * 2))) & 1;
    switch (geom) {
        case 0: return {0.5, 0.5, 0.55};
        case 1: return odd ? V3{0.85, 0.85, 0.8} : V3{0.2, 0.25, 0.5};
        case 2: return odd ? V3{0.9, 0.8, 0.6} : V3{0.5, 0.2, 0.15};
        case 3: return odd ? V3{0.8, 0.9, 0.8} : V3{0.15, 0.4, 0.2};
        case 4: return {0.8, 0.2, 0.15};
        default: return {0.3, 0.6, 0.3};
    }
}

// Direct shading: ambient + Lambert toward a fixed light, normal facing `to_eye`.
V3 direct(unsigned geom, V3 p, V3 ng, V3 to_eye) {
    V3 n = normalize(ng);
    if (scene::dot(n, to_eye) < 0) n = -1.0 * n;
    const V3 l = normalize({0.4, 0.8, 0.45});
    const double lam = std::max(0.0, scene::dot(n, l));
    const V3 a = albedo(geom, p);
    return (0.35 + 0.9 * lam) * a;
}

// Radiance along o + t d (t > tnear): direct color of the first hit or env.
V3 radiance(RTCScene s, V3 o, V3 d, float tnear) {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRayHit rh{};
    rh.ray.org_x = float(o.x);
    rh.ray.org_y = float(o.y);
    rh.ray.org_z = float(o.z);
    rh.ray.dir_x = float(d.x);
    rh.ray.dir_y = float(d.y);
    rh.ray.dir_z = float(d.z);
    rh.ray.tnear = tnear;
    rh.ray.tfar = kInf;
    rh.ray.mask = 0xFFFFFFFFu;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(s, &ctx, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return env(d);
    const V3 p = o + double(rh.ray.tfar) * d;
    return direct(rh.hit.geomID, p, {rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z}, -1.0 * d);
}

double srgb8(double c) {
    c = std::min(1.0, std::max(0.0, c));
    const double s = c <= 0.0031308 ? 12.92 * c : 1.055 * std::pow(c, 1.0 / 2.4) - 0.055;
    return std::round(s * 255.0);
}

double mad(const std::vector<V3>& a, const std::vector<V3>& b) {
    double sum = 0;
    for (size_t i = 0; i < a.size(); ++i)
        sum += std::fabs(srgb8(a[i].x) - srgb8(b[i].x)) + std::fabs(srgb8(a[i].y) - srgb8(b[i].y)) +
               std::fabs(srgb8(a[i].z) - srgb8(b[i].z));
    return sum / (3.0 * double(std::max<size_t>(a.size(), 1)));
}

double seconds(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

struct Pixel {
    uint32_t index;
    V3 p, n, mirror, to_eye;
    double z;
};

}  // namespace

int main() {
    scene::set_ftz_daz();
    scene::Device dev("threads=1");
    Room room;
    std::vector<const scene::Mesh*> ptrs;
    for (const auto& m : room.meshes) ptrs.push_back(&m);
    scene::Scene sc(dev.device, ptrs);

    refl_camera cam{};
    REQUIRE(refl_camera_look_at(&cam, rv({0.5, 1.7, 5.0}), rv({0.0, 0.6, -2.0}), rv({0, 1, 0}), 1.0f, 0.1f, 100.0f,
                                kW, kH) == REFL_STATUS_OK);
    refl_camera cam_inf = cam;
    cam_inf.z_far = kInf;
    const double tan_y = std::tan(0.5), pixel_angle = 2.0 * tan_y / kH;

    // Primary view: depth (reversed-Z, infinite far), direct color, floor pixels.
    const size_t n = size_t(kW) * kH;
    std::vector<float> depth(n);
    std::vector<refl_vec3> lit(n);
    std::vector<Pixel> floor_px;
    for (uint32_t y = 0; y < kH; ++y)
        for (uint32_t x = 0; x < kW; ++x) {
            refl_ray r{};
            REQUIRE(refl_camera_primary_ray(&r, &cam, {float(x) + 0.5f, float(y) + 0.5f}) == REFL_STATUS_OK);
            const V3 o{r.origin.x, r.origin.y, r.origin.z}, d{r.dir.x, r.dir.y, r.dir.z};
            RTCIntersectContext ctx;
            rtcInitIntersectContext(&ctx);
            RTCRayHit rh{};
            rh.ray.org_x = r.origin.x;
            rh.ray.org_y = r.origin.y;
            rh.ray.org_z = r.origin.z;
            rh.ray.dir_x = r.dir.x;
            rh.ray.dir_y = r.dir.y;
            rh.ray.dir_z = r.dir.z;
            rh.ray.tnear = 0;
            rh.ray.tfar = kInf;
            rh.ray.mask = 0xFFFFFFFFu;
            rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
            rtcIntersect1(sc.scene, &ctx, &rh);
            const size_t i = size_t(y) * kW + x;
            if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) {
                depth[i] = 0.0f;  // reversed-Z background
                lit[i] = rv(env(d));
                continue;
            }
            const V3 p = o + double(rh.ray.tfar) * d;
            V3 ng = normalize({rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z});
            if (scene::dot(ng, d) > 0) ng = -1.0 * ng;
            float lin = 0;
            REQUIRE(refl_camera_linear_depth(&lin, &cam, rv(p)) == REFL_STATUS_OK);
            REQUIRE(refl_camera_encode_depth(&depth[i], &cam_inf, lin, REFL_DEPTH_CONVENTION_REVERSED_Z) ==
                    REFL_STATUS_OK);
            lit[i] = rv(direct(rh.hit.geomID, p, ng, -1.0 * d));
            if (rh.hit.geomID == 0) {
                const V3 v = -1.0 * d;
                const V3 m = 2.0 * scene::dot(ng, v) * ng - v;
                floor_px.push_back({uint32_t(i), p, ng, normalize(m), v, double(lin)});
            }
        }
    REQUIRE(floor_px.size() > 1000);
    const double power = 2.0 / std::pow(kRoughness, 4) - 2.0;

    // Monte-Carlo reference at `spp` samples per floor pixel.
    auto reference = [&](uint32_t spp) {
        std::vector<V3> out(floor_px.size());
        for (size_t k = 0; k < floor_px.size(); ++k) {
            const Pixel& px = floor_px[k];
            const uint32_t hsh = hash32(px.index);
            const double rot_x = (hsh & 0xffffu) / 65536.0, rot_y = (hsh >> 16) / 65536.0;
            V3 t = std::fabs(px.mirror.x) < 0.9 ? V3{1, 0, 0} : V3{0, 1, 0};
            t = normalize(cross(px.mirror, t));
            const V3 b = cross(px.mirror, t);
            V3 sum{0, 0, 0};
            uint32_t accepted = 0;
            for (uint32_t s = 0; s < spp; ++s) {
                double u = double(s) / spp + rot_x;
                // Radical inverse base 2 of s.
                uint32_t bits = s;
                bits = (bits << 16) | (bits >> 16);
                bits = ((bits & 0x55555555u) << 1) | ((bits & 0xAAAAAAAAu) >> 1);
                bits = ((bits & 0x33333333u) << 2) | ((bits & 0xCCCCCCCCu) >> 2);
                bits = ((bits & 0x0F0F0F0Fu) << 4) | ((bits & 0xF0F0F0F0u) >> 4);
                bits = ((bits & 0x00FF00FFu) << 8) | ((bits & 0xFF00FF00u) >> 8);
                double v = double(bits) / 4294967296.0 + rot_y;
                u -= std::floor(u);
                v -= std::floor(v);
                const double ct = std::pow(u, 1.0 / (power + 1.0)), st = std::sqrt(std::max(0.0, 1 - ct * ct));
                const double ph = 2 * kPi * v;
                const V3 d = normalize(ct * px.mirror + (st * std::cos(ph)) * t + (st * std::sin(ph)) * b);
                if (scene::dot(d, px.n) <= 0) continue;
                sum = sum + radiance(sc.scene, px.p, d, 1e-4f);
                ++accepted;
            }
            out[k] = accepted ? (1.0 / accepted) * sum : radiance(sc.scene, px.p, px.mirror, 1e-4f);
        }
        return out;
    };
    auto t0 = Clock::now();
    const std::vector<V3> truth = reference(kTruth);
    const double truth_s = seconds(t0);
    const std::vector<V3> half = reference(kTruth / 2);
    const double noise = mad(truth, half);
    std::printf("cone_embree: %u x %u, %zu floor pixels, roughness %.2f (Phong power %.1f)\n", kW, kH,
                floor_px.size(), kRoughness, power);
    std::printf("converged reference %u spp: %.2f s; MAD to %u spp %.3f/255 (its own noise ~%.3f/255)\n", kTruth,
                truth_s, kTruth / 2, noise, noise / std::sqrt(3.0));
    // The difference of independent estimates at N and N/2 samples has
    // variance 3 sigma_N^2: the converged reference's own noise is about
    // MAD / sqrt(3), and must stay under 1/255.
    CHECK(noise / std::sqrt(3.0) < 1.0);

    std::printf("%-22s %10s %10s\n", "method", "ms", "MAD/255");
    std::vector<std::pair<double, double>> ref_pts;
    for (uint32_t spp : {4u, 8u, 16u, 32u, 64u}) {
        t0 = Clock::now();
        const std::vector<V3> r = reference(spp);
        const double ms = seconds(t0) * 1e3, e = mad(truth, r);
        ref_pts.push_back({e, ms});
        std::printf("embree mc spp=%-8u %10.2f %10.3f\n", spp, ms, e);
    }

    // refl: pyramids and cone trace.
    size_t hz_len = 0;
    uint32_t levels = 0;
    REQUIRE(refl_hiz_len(&hz_len, &levels, kW, kH) == REFL_STATUS_OK);
    size_t pyr_len = 0, vis_len = 0;
    REQUIRE(refl_cone_pyramid_len(&pyr_len, &vis_len, kW, kH) == REFL_STATUS_OK);
    std::vector<refl_vec2> hz(hz_len);
    std::vector<refl_vec3> color(pyr_len);
    std::vector<float> vis(vis_len);
    const refl_depth_image dimg{{depth.data(), n, kW, kH, kW}, cam_inf, REFL_DEPTH_CONVENTION_REVERSED_Z};
    const refl_image_vec3 limg{lit.data(), n, kW, kH, kW};
    const refl_hiz hiz{hz.data(), hz_len, cam_inf, REFL_DEPTH_CONVENTION_REVERSED_Z};
    const refl_cone_pyramids pyr{hiz, color.data(), pyr_len, vis.data(), vis_len};
    refl_hiz_options hopts = refl_hiz_options_default();
    const refl_trace_thickness thick{0.06f, {nullptr, 0, 0, 0, 0}};
    float theta = 0;
    REQUIRE(refl_cone_angle_from_roughness(&theta, float(kRoughness)) == REFL_STATUS_OK);

    auto run_cone = [&](uint32_t circles, std::vector<V3>& out) {
        REQUIRE(refl_hiz_build(hz.data(), hz_len, &dimg) == REFL_STATUS_OK);
        REQUIRE(refl_cone_build_color(color.data(), pyr_len, &limg, 1.0f) == REFL_STATUS_OK);
        REQUIRE(refl_cone_build_visibility(vis.data(), vis_len, &hiz) == REFL_STATUS_OK);
        refl_cone_options co = refl_cone_options_default();
        co.max_circles = circles;
        co.normalize = 1;
        size_t hits = 0;
        for (size_t k = 0; k < floor_px.size(); ++k) {
            const Pixel& px = floor_px[k];
            const double cosv = std::min(1.0, std::max(1.0 / 16, scene::dot(px.to_eye, px.n)));
            const double tanv = std::sqrt(1 - cosv * cosv) / cosv;
            const double t_start = 0.5 * px.z * pixel_angle * tanv;
            const V3 o = px.p + 2.4e-3 * px.n + t_start * px.mirror;
            const refl_ray ray{rv(o), rv(px.mirror)};
            refl_trace_result tr{};
            REQUIRE(refl_hiz_trace_ray(&tr, &hiz, &thick, ray, kInf, &hopts) == REFL_STATUS_OK);
            const V3 fb = env(px.mirror);
            if (tr.miss != REFL_TRACE_MISS_NONE) {
                out[k] = fb;
                continue;
            }
            ++hits;
            refl_projection ap{};
            REQUIRE(refl_camera_project(&ap, &cam_inf, ray.origin) == REFL_STATUS_OK);
            const refl_cone c{{ap.x, ap.y}, ap.depth, tr.pixel, tr.depth, theta, float(cosv), 0.0f};
            refl_cone_result res{};
            REQUIRE(refl_cone_trace(&res, &pyr, &c, rv(fb), &co) == REFL_STATUS_OK);
            CHECK(std::isfinite(res.color.x) && std::isfinite(res.color.y) && std::isfinite(res.color.z));
            out[k] = {res.color.x, res.color.y, res.color.z};
        }
        return hits;
    };
    std::vector<V3> env_only(floor_px.size());
    for (size_t k = 0; k < floor_px.size(); ++k) env_only[k] = env(floor_px[k].mirror);
    const double env_err = mad(truth, env_only);
    std::printf("%-22s %10s %10.3f\n", "environment only", "-", env_err);
    for (uint32_t circles : {4u, 8u, 16u}) {
        std::vector<V3> out(floor_px.size());
        std::vector<double> times;
        size_t hits = 0;
        for (int rep = 0; rep < 3; ++rep) {
            t0 = Clock::now();
            hits = run_cone(circles, out);
            times.push_back(seconds(t0) * 1e3);
        }
        std::sort(times.begin(), times.end());
        const double ms = times[1], e = mad(truth, out);
        // Reference time at this error: log-log between reference rows.
        std::sort(ref_pts.begin(), ref_pts.end(), [](auto a, auto b) { return a.first > b.first; });
        double eq = 0;
        if (e >= ref_pts.front().first) {
            eq = ref_pts.front().second * std::pow(ref_pts.front().first / e, 2);
        } else if (e <= ref_pts.back().first) {
            eq = ref_pts.back().second * std::pow(ref_pts.back().first / e, 2);
        } else {
            for (size_t j = 0; j + 1 < ref_pts.size(); ++j) {
                const auto a = ref_pts[j], b = ref_pts[j + 1];
                if (e <= a.first && e >= b.first) {
                    const double s = (std::log(e) - std::log(a.first)) / (std::log(b.first) - std::log(a.first));
                    eq = std::exp(std::log(a.second) + s * (std::log(b.second) - std::log(a.second)));
                }
            }
        }
        std::printf("refl cone circles=%-4u %10.2f %10.3f   axis hits %.3f, embree at equal error %.2f ms: ratio %.1fx\n",
                    circles, ms, e, double(hits) / floor_px.size(), eq, eq / ms);
        CHECK(e < env_err);
    }
    return check::finish("cone_embree");
}
