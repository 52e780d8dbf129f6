// depth_image_embree: refl's depth-image kernels (per-pixel stepping,
// refl_step_rays, and Hi-Z traversal, refl_hiz_*) through the C ABI against
// Embree 3 (rtcIntersect1) on the same reflection rays.
//
// Usage:
//     depth_image_embree            the harness's own scene (built here)
//     depth_image_embree <dir>      the room scene of a directory written by
//                                   `refl export-crosscheck` (crosscheck.hpp)
//
// Per scene:
//  * Embree renders the primary view's depth buffer: one primary ray per
//    pixel center (src/export.rs crosscheck_rays: computed in double, cast
//    once), linear depth z = t * (-dir_view.z), nothing hit = the far plane.
//    refl_camera_encode_depth stores it in the three conventions: Linear and
//    ZeroToOne with the camera's far plane, ReversedZ with an infinite one.
//  * Reflection rays: the crosscheck's (the first reflection_count rays of
//    rays.bin, on a surface, tmin = epsilon) or, for the own scene, one per
//    mirror-floor pixel (exact plane hit and mirror direction in double).
//    The reference is rtcIntersect1 of these rays. The kernels trace the same
//    line with its origin moved as src/screen.rs does: 2e-4 scene diameters
//    along the origin surface's geometric normal (Embree's Ng of the primary
//    ray from the eye to the origin, facing the eye), then
//    t0 = START_SLOPES (0.5) * z * pixel_angle * tan(theta) along the ray
//    (theta between the view direction and the normal, tan clamped to 16).
//  * Visible: the reference hit projects into the image and Embree's primary
//    depth at that pixel is within 2% (relative) of the hit's linear depth.
//    Found: a kernel hit within 1 px (Euclidean) of the reference hit's
//    projection. False hit: a hit on a ray whose reference is not visible.
//  * Kernels: stepping with stride 1, 4, 16; Hi-Z with its default options
//    and three variants; stride 1 and default Hi-Z again with
//    refl_trace_refine_hit on every hit; constant thickness 0.005 scene diameters;
//    every convention. Timed on one thread and on all hardware threads (std::thread
//    chunks), next to rtcIntersect1 on the same (original) rays.
//
// Checks (correctness only, never time): every status OK, no NaN in any
// result, hit rate on visible rays >= 0.95 for stride 1 and every Hi-Z
// setting in every convention, refinement never lowers the hit rate, Hi-Z
// agrees with stride-1 stepping (both miss,
// or both hit within one pixel) on >= 99% of the rays, the multi-threaded
// row-band pyramid build is bit-identical to refl_hiz_build. Own scene only:
// on a synthetic set of long rays (projected walk > 256 px) the unit-step /
// Hi-Z fetch ratio is >= 10 in every convention, and Hi-Z still agrees with
// stepping on >= 99% of them. The own scene also prints the cost growth at
// about 10k, 100k and 1M triangles (Embree BVH build and trace vs. refl per
// ray; the depth buffer rendering is excluded from every refl time).
#include <embree3/rtcore.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <string>
#include <thread>
#include <vector>

#include "check.hpp"
#include "crosscheck.hpp"
#include "refl.h"
#include "scene.hpp"

namespace {

using scene::V3;
using Clock = std::chrono::steady_clock;

#ifdef REFL_SANITIZE
constexpr bool kSanitized = true;
#else
constexpr bool kSanitized = false;
#endif

// src/screen.rs: START_SLOPES, VISIBLE_DEPTH_TOLERANCE, FOUND_RADIUS_PX,
// THICKNESS_OF_DIAMETER, and the normal bias of reflection_rays.
constexpr double kStartSlopes = 0.5;
constexpr double kVisibleTolerance = 0.02;
constexpr double kFoundRadiusPx = 1.0;
constexpr double kThicknessOfDiameter = 0.005;
constexpr double kBiasOfDiameter = 2e-4;
constexpr double kLongRayPx = 256.0;
constexpr int kTimingRuns = 3;
constexpr float kInf = std::numeric_limits<float>::infinity();

const uint32_t kConventions[3] = {REFL_DEPTH_CONVENTION_LINEAR, REFL_DEPTH_CONVENTION_ZERO_TO_ONE,
                                  REFL_DEPTH_CONVENTION_REVERSED_Z};

const char* convention_name(uint32_t c) {
    switch (c) {
        case REFL_DEPTH_CONVENTION_LINEAR: return "linear";
        case REFL_DEPTH_CONVENTION_ZERO_TO_ONE: return "0to1";
        case REFL_DEPTH_CONVENTION_REVERSED_Z: return "revZinf";
        default: return "?";
    }
}

V3 normalize(V3 a) { return (1.0 / scene::length(a)) * a; }
refl_vec3 rv(V3 v) { return {static_cast<float>(v.x), static_cast<float>(v.y), static_cast<float>(v.z)}; }
V3 dv(refl_vec3 v) { return {v.x, v.y, v.z}; }

unsigned hardware_threads() {
    const unsigned n = std::thread::hardware_concurrency();
    return n ? n : 1;
}

// f(begin, end) over contiguous chunks of [0, count) on `threads` threads
// (the calling thread alone for one). Workers set FTZ/DAZ as the main thread.
template <class F>
void parallel_for(size_t count, unsigned threads, const F& f) {
    if (threads <= 1 || count < 2) {
        if (count) f(size_t(0), count);
        return;
    }
    std::vector<std::thread> pool;
    const size_t chunk = (count + threads - 1) / threads;
    for (unsigned k = 0; k < threads; ++k) {
        const size_t b = std::min(count, size_t(k) * chunk), e = std::min(count, b + chunk);
        if (b < e)
            pool.emplace_back([&f, b, e] {
                scene::set_ftz_daz();
                f(b, e);
            });
    }
    for (auto& t : pool) t.join();
}

// Median wall time of `runs` calls of f, seconds.
template <class F>
double median_seconds(int runs, const F& f) {
    std::vector<double> s;
    for (int r = 0; r < runs; ++r) {
        const auto t0 = Clock::now();
        f();
        s.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
    }
    std::sort(s.begin(), s.end());
    return s[s.size() / 2];
}

double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

// rtcIntersect1 returning the geometric normal as well.
struct NgHit {
    bool hit = false;
    float t = kInf;
    V3 ng{0, 0, 0};
};
NgHit trace_ng(RTCScene s, const float o[3], const float d[3], float tnear, float tfar) {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    RTCRayHit rh{};
    rh.ray.org_x = o[0];
    rh.ray.org_y = o[1];
    rh.ray.org_z = o[2];
    rh.ray.dir_x = d[0];
    rh.ray.dir_y = d[1];
    rh.ray.dir_z = d[2];
    rh.ray.tnear = tnear;
    rh.ray.tfar = tfar;
    rh.ray.mask = 0xFFFFFFFFu;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(s, &ctx, &rh);
    NgHit h;
    if (rh.hit.geomID != RTC_INVALID_GEOMETRY_ID) {
        h.hit = true;
        h.t = rh.ray.tfar;
        h.ng = {rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z};
    }
    return h;
}

// The primary view: refl cameras (far plane finite, and infinite for
// reversed-Z), the double-precision ray formula of src/export.rs and
// Embree's depth buffer.
struct View {
    refl_camera cam{}, cam_inf{};
    double inv[16] = {}, view[16] = {};
    double tan_x = 0, tan_y = 0, pixel_angle = 0;
    uint32_t w = 0, h = 0;
    V3 eye{0, 0, 0};
    std::vector<double> lin;  // Embree linear depth per pixel, +inf: nothing hit

    explicit View(const refl_camera& c) : cam(c), cam_inf(c) {
        cam_inf.z_far = kInf;
        REQUIRE(refl_camera_validate(&cam) == REFL_STATUS_OK);
        REQUIRE(refl_camera_validate(&cam_inf) == REFL_STATUS_OK);
        refl_mat4 m;
        REQUIRE(refl_camera_inverse_view(&m, &cam) == REFL_STATUS_OK);
        for (int k = 0; k < 16; ++k) {
            inv[k] = m.m[k];
            view[k] = cam.view.m[k];
        }
        w = cam.width;
        h = cam.height;
        tan_y = std::tan(double(cam.fov_y) * 0.5);
        tan_x = tan_y * double(w) / double(h);
        pixel_angle = 2.0 * tan_y / double(h);
        eye = {inv[12], inv[13], inv[14]};
    }
    // Unit world direction of the primary ray through pixel (x, y)'s center
    // (src/export.rs crosscheck_rays).
    V3 primary_dir(uint32_t x, uint32_t y) const {
        const double ndc_x = 2.0 * (double(x) + 0.5) / double(w) - 1.0;
        const double ndc_y = 1.0 - 2.0 * (double(y) + 0.5) / double(h);
        const V3 d{ndc_x * tan_x, ndc_y * tan_y, -1.0};
        return normalize({inv[0] * d.x + inv[4] * d.y + inv[8] * d.z, inv[1] * d.x + inv[5] * d.y + inv[9] * d.z,
                          inv[2] * d.x + inv[6] * d.y + inv[10] * d.z});
    }
    // -z of a world direction in view space.
    double view_forward(V3 d) const { return -(view[2] * d.x + view[6] * d.y + view[10] * d.z); }
    double linear_depth(V3 p) const { return -(view[2] * p.x + view[6] * p.y + view[10] * p.z + view[14]); }

    void render(RTCScene s, unsigned threads) {
        lin.assign(size_t(w) * h, std::numeric_limits<double>::infinity());
        const float o[3] = {float(eye.x), float(eye.y), float(eye.z)};
        parallel_for(h, threads, [&](size_t y0, size_t y1) {
            for (size_t y = y0; y < y1; ++y)
                for (uint32_t x = 0; x < w; ++x) {
                    const V3 dd = primary_dir(x, uint32_t(y));
                    const float d[3] = {float(dd.x), float(dd.y), float(dd.z)};
                    const scene::Hit hh = scene::trace(s, o, d, 0.0f);
                    if (hh.hit()) lin[y * w + x] = double(hh.t) * view_forward({d[0], d[1], d[2]});
                }
        });
    }
};

// One depth buffer in one convention, encoded by refl.
struct DepthBuf {
    uint32_t conv = 0;
    refl_camera cam{};
    std::vector<float> data;
    refl_depth_image image() const {
        refl_depth_image im{};
        im.depth = {data.data(), data.size(), cam.width, cam.height, cam.width};
        im.camera = cam;
        im.convention = conv;
        return im;
    }
};

DepthBuf encode(const View& v, uint32_t conv) {
    DepthBuf b;
    b.conv = conv;
    b.cam = conv == REFL_DEPTH_CONVENTION_REVERSED_Z ? v.cam_inf : v.cam;
    b.data.resize(v.lin.size());
    size_t bad = 0;
    for (size_t i = 0; i < v.lin.size(); ++i) {
        const float z = std::isfinite(v.lin[i]) ? float(v.lin[i]) : b.cam.z_far;
        float d = 0.0f;
        if (refl_camera_encode_depth(&d, &b.cam, z, conv) != REFL_STATUS_OK) ++bad;
        b.data[i] = d;
    }
    CHECK(bad == 0);
    return b;
}

// Reflection rays with their reference hits.
struct Rays {
    std::vector<refl_ray> ray;     // as the reference traces it (origin on the surface)
    std::vector<refl_ray> screen;  // as the kernels trace it (origin moved, src/screen.rs)
    float tmin = 0.0f;
    std::vector<uint8_t> ref_hit, ref_proj, visible;
    std::vector<float> ref_px, ref_py;  // projection of the reference hit
    size_t normal_fallbacks = 0;        // origins whose Ng the eye ray did not find
    size_t size() const { return ray.size(); }
    size_t visible_count() const { return size_t(std::count(visible.begin(), visible.end(), 1)); }
};

// The kernels' ray for the reference ray (o, d) (src/screen.rs
// reflection_rays). `fallbacks` counts origins whose surface the eye ray did
// not reach; their normal is the mirror normal d - primary direction.
refl_ray screen_ray(const View& v, RTCScene s, V3 o, V3 d, double bias, std::atomic<size_t>& fallbacks) {
    const V3 to = o - v.eye;
    const double dist = scene::length(to);
    const V3 pd = (1.0 / dist) * to;
    const float eo[3] = {float(v.eye.x), float(v.eye.y), float(v.eye.z)};
    const float ed[3] = {float(pd.x), float(pd.y), float(pd.z)};
    const NgHit h = trace_ng(s, eo, ed, 0.0f, float(dist * (1.0 + 1e-3)));
    V3 ng;
    if (h.hit && std::fabs(double(h.t) - dist) <= 1e-3 * dist && scene::length(h.ng) > 0.0) {
        ng = normalize(h.ng);
        if (scene::dot(ng, pd) > 0.0) ng = -1.0 * ng;
    } else {
        ++fallbacks;
        ng = normalize(d - pd);
    }
    const V3 view = -1.0 * pd;
    const double cs = std::clamp(scene::dot(view, ng), 1.0 / 16.0, 1.0);
    const double tn = std::sqrt(1.0 - cs * cs) / cs;
    const double t0 = kStartSlopes * v.linear_depth(o) * v.pixel_angle * tn;
    return {rv(o + bias * ng + t0 * d), rv(d)};
}

// Fills screen rays, reference hits, projections and visibility of r.ray.
void finish_rays(Rays& r, const View& v, RTCScene s, double diameter, unsigned threads) {
    const size_t n = r.size();
    r.screen.resize(n);
    r.ref_hit.assign(n, 0);
    r.ref_proj.assign(n, 0);
    r.visible.assign(n, 0);
    r.ref_px.assign(n, 0.0f);
    r.ref_py.assign(n, 0.0f);
    std::atomic<size_t> fallbacks{0}, bad_status{0};
    const double bias = kBiasOfDiameter * diameter;
    parallel_for(n, threads, [&](size_t b, size_t e) {
        for (size_t i = b; i < e; ++i) {
            const refl_ray& q = r.ray[i];
            const V3 o = dv(q.origin), d = dv(q.dir);
            r.screen[i] = screen_ray(v, s, o, d, bias, fallbacks);
            const float fo[3] = {q.origin.x, q.origin.y, q.origin.z}, fd[3] = {q.dir.x, q.dir.y, q.dir.z};
            const scene::Hit h = scene::trace(s, fo, fd, r.tmin);
            if (!h.hit()) continue;
            r.ref_hit[i] = 1;
            refl_projection p{};
            if (refl_camera_project(&p, &v.cam, rv(o + double(h.t) * d)) != REFL_STATUS_OK) {
                ++bad_status;
                continue;
            }
            if (!p.valid) continue;
            r.ref_proj[i] = 1;
            r.ref_px[i] = p.x;
            r.ref_py[i] = p.y;
            if (!(p.x >= 0.0f && p.y >= 0.0f && p.x < float(v.w) && p.y < float(v.h))) continue;
            const double z = v.lin[size_t(p.y) * v.w + size_t(p.x)];
            r.visible[i] = std::isfinite(z) && std::fabs(z - double(p.depth)) <= kVisibleTolerance * double(p.depth);
        }
    });
    r.normal_fallbacks = fallbacks;
    CHECK(bad_status == 0);
}

// A kernel and its setting.
struct Kernel {
    std::string kind, setting;
    bool hiz = false;
    bool refine = false;  // refl_trace_refine_hit on every hit (inside the timed pass)
    refl_step_options step{1, UINT32_MAX};
    refl_hiz_options hopt{};
};

std::vector<Kernel> kernels() {
    std::vector<Kernel> k;
    for (uint32_t s : {1u, 4u, 16u}) {
        Kernel x;
        x.kind = "step";
        x.setting = "stride " + std::to_string(s);
        x.step = {s, UINT32_MAX};
        k.push_back(x);
    }
    refl_hiz_options def = refl_hiz_options_default();
    auto hiz = [&](const std::string& name, refl_hiz_options o) {
        Kernel x;
        x.kind = "hiz";
        x.hiz = true;
        x.setting = name;
        x.hopt = o;
        k.push_back(x);
    };
    hiz("default (s" + std::to_string(def.start_level) + " e" + std::to_string(def.stop_level) + " p" +
            std::to_string(def.prologue_steps) + ")",
        def);
    refl_hiz_options o = def;
    o.start_level = 0;
    o.prologue_steps = 0;
    hiz("start 0, no prologue", o);
    o = def;
    o.start_level = 5;
    hiz("start 5", o);
    o = def;
    o.stop_level = 2;
    hiz("stop 2", o);
    // The same kernels with sub-texel refinement of every hit.
    Kernel r1 = k[0];
    r1.setting += " + refine";
    r1.refine = true;
    k.push_back(r1);
    Kernel r2 = k[3];
    r2.setting += " + refine";
    r2.refine = true;
    k.push_back(r2);
    return k;
}

// What a kernel traces against: image, pyramid, thickness.
struct Target {
    refl_depth_image image{};
    refl_hiz hiz{};
    refl_trace_thickness thickness{};
};

uint32_t trace_chunk(const Kernel& k, const Target& t, const refl_ray* rays, size_t n, refl_trace_result* out) {
    const float tmax = kInf;
    const refl_status s = k.hiz ? refl_hiz_trace_rays(out, n, &t.hiz, &t.thickness, rays, n, &tmax, 1, &k.hopt)
                                : refl_step_rays(out, n, &t.image, &t.thickness, rays, n, &tmax, 1, &k.step);
    if (s != REFL_STATUS_OK || !k.refine) return s;
    for (size_t i = 0; i < n; ++i) {
        if (out[i].miss != REFL_TRACE_MISS_NONE) continue;
        const refl_trace_result hit = out[i];
        const refl_status r = refl_trace_refine_hit(&out[i], &t.image, rays[i], tmax, &hit);
        if (r != REFL_STATUS_OK) return r;
    }
    return REFL_STATUS_OK;
}

// Traces all rays on `threads` threads; false if a call failed.
bool trace_all(const Kernel& k, const Target& t, const std::vector<refl_ray>& rays,
               std::vector<refl_trace_result>& out, unsigned threads) {
    out.resize(rays.size());
    std::atomic<size_t> bad{0};
    parallel_for(rays.size(), threads, [&](size_t b, size_t e) {
        if (trace_chunk(k, t, rays.data() + b, e - b, out.data() + b) != REFL_STATUS_OK) ++bad;
    });
    return bad == 0;
}

bool finite_result(const refl_trace_result& r) {
    return std::isfinite(r.pixel.x) && std::isfinite(r.pixel.y) && std::isfinite(r.t) && std::isfinite(r.depth) &&
           std::isfinite(r.surface_depth);
}

struct Stats {
    size_t rays = 0, visible = 0, found = 0, wrong = 0, missed = 0, false_hits = 0, nan = 0, err_n = 0;
    double err_sum = 0.0;
    uint64_t fetches = 0;
    double hit_rate() const { return visible ? double(found) / double(visible) : 0.0; }
    double false_rate() const { return rays > visible ? double(false_hits) / double(rays - visible) : 0.0; }
};

Stats evaluate(const Rays& r, const std::vector<refl_trace_result>& t) {
    Stats s;
    s.rays = r.size();
    for (size_t i = 0; i < t.size(); ++i) {
        s.fetches += t[i].fetches;
        s.nan += !finite_result(t[i]);
        const bool hit = t[i].miss == REFL_TRACE_MISS_NONE, vis = r.visible[i] != 0;
        s.visible += vis;
        if (hit && vis) {
            const double err = std::hypot(double(t[i].pixel.x) - r.ref_px[i], double(t[i].pixel.y) - r.ref_py[i]);
            s.err_sum += err;
            ++s.err_n;
            if (err <= kFoundRadiusPx) ++s.found;
            else ++s.wrong;
        } else if (vis) {
            ++s.missed;
        } else if (hit) {
            ++s.false_hits;
        }
    }
    return s;
}

// Both miss, or both hit within one pixel of each other.
bool same_hit(const refl_trace_result& a, const refl_trace_result& b) {
    const bool ha = a.miss == REFL_TRACE_MISS_NONE, hb = b.miss == REFL_TRACE_MISS_NONE;
    if (ha != hb) return false;
    return !ha || std::hypot(double(a.pixel.x) - b.pixel.x, double(a.pixel.y) - b.pixel.y) <= 1.0;
}

double agreement(const std::vector<refl_trace_result>& a, const std::vector<refl_trace_result>& b) {
    size_t n = 0;
    for (size_t i = 0; i < a.size(); ++i) n += same_hit(a[i], b[i]);
    return a.empty() ? 1.0 : double(n) / double(a.size());
}

// Rays both kernels hit at the same place after walking more than
// kLongRayPx pixels from the projection of the ray's origin; their fetches.
struct LongRays {
    size_t n = 0;
    uint64_t step_fetches = 0, hiz_fetches = 0;
    double ratio() const { return hiz_fetches ? double(step_fetches) / double(hiz_fetches) : 0.0; }
};
LongRays long_rays(const View& v, const std::vector<refl_ray>& rays, const std::vector<refl_trace_result>& step,
                   const std::vector<refl_trace_result>& hiz) {
    LongRays l;
    for (size_t i = 0; i < rays.size(); ++i) {
        if (step[i].miss != REFL_TRACE_MISS_NONE || !same_hit(step[i], hiz[i])) continue;
        refl_projection p{};
        if (refl_camera_project(&p, &v.cam, rays[i].origin) != REFL_STATUS_OK || !p.valid) continue;
        if (std::hypot(double(step[i].pixel.x) - p.x, double(step[i].pixel.y) - p.y) <= kLongRayPx) continue;
        ++l.n;
        l.step_fetches += step[i].fetches;
        l.hiz_fetches += hiz[i].fetches;
    }
    return l;
}

// Median ns per ray of rtcIntersect1 over the reference rays.
double embree_ns(RTCScene s, const Rays& r, unsigned threads) {
    std::vector<float> sink(std::max<unsigned>(threads, 1) * 16, 0.0f);
    const double secs = median_seconds(kTimingRuns, [&] {
        std::atomic<unsigned> slot{0};
        parallel_for(r.size(), threads, [&](size_t b, size_t e) {
            float acc = 0.0f;
            for (size_t i = b; i < e; ++i) {
                const refl_ray& q = r.ray[i];
                const float o[3] = {q.origin.x, q.origin.y, q.origin.z}, d[3] = {q.dir.x, q.dir.y, q.dir.z};
                const scene::Hit h = scene::trace(s, o, d, r.tmin);
                if (h.hit()) acc += h.t;
            }
            sink[16 * (slot++ % threads)] += acc;
        });
    });
    return r.size() ? secs * 1e9 / double(r.size()) : 0.0;
}

// A pyramid of one depth buffer, built by refl_hiz_build (timed) and by
// row bands on several threads (checked bit-identical).
struct Pyramid {
    std::vector<refl_vec2> data;
    double build_ms = 0.0, build_ms_mt = 0.0;
};

Pyramid build_pyramid(const DepthBuf& db, unsigned threads) {
    Pyramid p;
    size_t len = 0;
    uint32_t levels = 0;
    REQUIRE(refl_hiz_len(&len, &levels, db.cam.width, db.cam.height) == REFL_STATUS_OK);
    p.data.assign(len, refl_vec2{0.0f, 0.0f});
    const refl_depth_image im = db.image();
    p.build_ms = 1e3 * median_seconds(kTimingRuns, [&] {
        CHECK_STATUS(refl_hiz_build(p.data.data(), p.data.size(), &im), REFL_STATUS_OK);
    });
    std::vector<refl_vec2> bands(len, refl_vec2{0.0f, 0.0f});
    p.build_ms_mt = 1e3 * median_seconds(kTimingRuns, [&] {
        for (uint32_t level = 0; level < levels; ++level) {
            refl_hiz_level_info info{};
            CHECK_STATUS(refl_hiz_level(&info, db.cam.width, db.cam.height, level), REFL_STATUS_OK);
            std::atomic<size_t> bad{0};
            parallel_for(info.height, threads, [&](size_t b, size_t e) {
                if (refl_hiz_build_rows(bands.data(), bands.size(), &im, level, refl_row_range{uint32_t(b), uint32_t(e)}) !=
                    REFL_STATUS_OK)
                    ++bad;
            });
            CHECK(bad == 0);
        }
    });
    CHECK(std::memcmp(bands.data(), p.data.data(), len * sizeof(refl_vec2)) == 0);
    return p;
}

void print_header() {
    std::printf("  %-5s %-32s %-7s %7s %6s %7s %6s %6s %7s %6s %8s | %8s %8s %8s %8s %6s %6s\n", "kern", "setting",
                "conv", "rays", "vis%", "hitrate", "vmiss", "vwrong", "false", "errpx", "fetch/r", "ns/r 1t",
                "ns/r Nt", "embr 1t", "embr Nt", "x 1t", "x Nt");
}

// Runs every kernel in every convention on r, prints the table and checks.
// Returns nothing; failures are recorded by CHECK.
void run_kernels(const char* title, const View& v, RTCScene s, const Rays& r, double diameter,
                 const std::vector<refl_ray>* long_set) {
    const unsigned nt = hardware_threads();
    const double e1 = embree_ns(s, r, 1), en = embree_ns(s, r, nt);
    std::printf("\n== %s: %zu reflection rays, %zu visible (%.1f%%), %zu origin normals from the mirror fallback; "
                "thickness %.4g (0.005 diameters); %u threads ==\n",
                title, r.size(), r.visible_count(), r.size() ? 100.0 * double(r.visible_count()) / double(r.size()) : 0.0,
                r.normal_fallbacks, kThicknessOfDiameter * diameter, nt);
    std::printf("  rtcIntersect1 on the reference rays: %.1f ns/ray (1 thread), %.1f ns/ray (%u threads)\n", e1, en, nt);
    std::printf("  (refl times: tracing only; depth buffer rendering and encoding excluded, pyramid build listed "
                "separately; x = refl / Embree)\n");
    print_header();
    const std::vector<Kernel> ks = kernels();
    std::vector<std::string> agree_lines, long_lines;
    for (uint32_t conv : kConventions) {
        const DepthBuf db = encode(v, conv);
        const Pyramid pyr = build_pyramid(db, nt);
        Target t;
        t.image = db.image();
        t.hiz.data = pyr.data.data();
        t.hiz.len = pyr.data.size();
        t.hiz.camera = db.cam;
        t.hiz.convention = conv;
        t.thickness.constant = float(kThicknessOfDiameter * diameter);
        t.thickness.back_faces = refl_image_f32{nullptr, 0, 0, 0, 0};
        std::vector<refl_trace_result> step1, step1_long;
        double raw_hit_rate = 0.0;
        for (const Kernel& k : ks) {
            std::vector<refl_trace_result> out;
            bool ok = trace_all(k, t, r.screen, out, nt);
            CHECK(ok);
            const double s1 = median_seconds(kTimingRuns, [&] { ok &= trace_all(k, t, r.screen, out, 1); });
            const double sn = median_seconds(kTimingRuns, [&] { ok &= trace_all(k, t, r.screen, out, nt); });
            CHECK(ok);
            const Stats st = evaluate(r, out);
            const double n1 = r.size() ? s1 * 1e9 / double(r.size()) : 0.0, nn = r.size() ? sn * 1e9 / double(r.size()) : 0.0;
            std::printf("  %-5s %-32s %-7s %7zu %6.1f %7.4f %6zu %6zu %7.4f %6.3f %8.1f | %8.1f %8.1f %8.1f %8.1f %6.2f "
                        "%6.2f\n",
                        k.kind.c_str(), k.setting.c_str(), convention_name(conv), st.rays,
                        st.rays ? 100.0 * double(st.visible) / double(st.rays) : 0.0, st.hit_rate(), st.missed,
                        st.wrong, st.false_rate(), st.err_n ? st.err_sum / double(st.err_n) : 0.0,
                        st.rays ? double(st.fetches) / double(st.rays) : 0.0, n1, nn, e1, en, e1 > 0 ? n1 / e1 : 0.0,
                        en > 0 ? nn / en : 0.0);
            CHECK(st.nan == 0);
            if (k.hiz || k.step.stride == 1) {
                // The bound is on visible rays; a scene without any would make it vacuous.
                CHECK(st.visible > 0);
                if (!(st.hit_rate() >= 0.95))
                    std::fprintf(stderr, "hit rate %.4f < 0.95: %s %s %s\n", st.hit_rate(), k.kind.c_str(),
                                 k.setting.c_str(), convention_name(conv));
                CHECK(st.hit_rate() >= 0.95);
            }
            if (!k.hiz && k.step.stride == 1 && !k.refine) raw_hit_rate = st.hit_rate();
            // Refinement only moves hits onto the surface: never fewer found.
            if (k.refine) CHECK(st.hit_rate() >= raw_hit_rate);
            if (!k.hiz && k.step.stride == 1) {
                step1 = out;
            } else if (k.hiz) {
                const double a = agreement(step1, out);
                const LongRays l = long_rays(v, r.screen, step1, out);
                char line[256];
                std::snprintf(line, sizeof line,
                              "  %-7s %-32s agrees with stride 1 on %.4f of %zu rays; long rays (> %.0f px): %zu, "
                              "fetches stride 1 / hiz = %.2f",
                              convention_name(conv), k.setting.c_str(), a, out.size(), kLongRayPx, l.n, l.ratio());
                agree_lines.push_back(line);
                CHECK(a >= 0.99);
            }
        }
        char line[256];
        std::snprintf(line, sizeof line, "  %-7s pyramid %zu texels: refl_hiz_build %.2f ms (1 thread); refl_hiz_build_rows in bands, "
                      "threads started per level, %.2f ms (%u threads)",
                      convention_name(conv), pyr.data.size(), pyr.build_ms, pyr.build_ms_mt, nt);
        agree_lines.push_back(line);
        if (long_set) {
            // Synthetic long rays: stride 1 against every Hi-Z setting.
            std::vector<refl_trace_result> a, b;
            CHECK(trace_all(ks[0], t, *long_set, a, nt));
            for (const Kernel& k : ks) {
                if (!k.hiz || k.refine) continue;
                CHECK(trace_all(k, t, *long_set, b, nt));
                size_t nan = 0;
                for (const auto& x : b) nan += !finite_result(x);
                CHECK(nan == 0);
                const double ag = agreement(a, b);
                const LongRays l = long_rays(v, *long_set, a, b);
                std::snprintf(line, sizeof line,
                              "  %-7s %-32s synthetic set %zu rays: agreement %.4f; long rays (> %.0f px) %zu: "
                              "fetches/ray stride 1 %.1f, hiz %.1f, ratio %.2f",
                              convention_name(conv), k.setting.c_str(), long_set->size(), ag, kLongRayPx, l.n,
                              l.n ? double(l.step_fetches) / double(l.n) : 0.0,
                              l.n ? double(l.hiz_fetches) / double(l.n) : 0.0, l.ratio());
                long_lines.push_back(line);
                CHECK(ag >= 0.99);
                CHECK(l.n >= long_set->size() / 4);
                if (k.setting.rfind("default", 0) == 0) CHECK(l.ratio() >= 10.0);
            }
        }
    }
    std::printf("  Hi-Z vs stride-1 stepping (same thickness; both miss or both hit within 1 px):\n");
    for (const auto& l : agree_lines) std::printf("%s\n", l.c_str());
    if (long_set) {
        std::printf("  Long rays (synthetic: from halfway along a pixel's primary ray in the left quarter toward a "
                    "surface %u to %u px to its right, mirrored in y):\n",
                    v.w / 2 + 16, v.w / 2 + 16 + v.w / 8 - 1);
        for (const auto& l : long_lines) std::printf("%s\n", l.c_str());
    }
}

// ---------------------------------------------------------------------------
// The crosscheck directory (room scene).

void run_crosscheck(const std::string& dir) {
    const scene::Mesh mesh = crosscheck::load_obj(dir + "/scene.obj");
    if (mesh.triangle_count() == 0) crosscheck::die("scene.obj has no faces");
    const crosscheck::RaySet set = crosscheck::load_rays(dir);
    const auto meta = crosscheck::load_meta(dir);
    refl_camera cam{};
    {
        std::istringstream vs(crosscheck::meta_get(meta, "view"));
        for (float& x : cam.view.m) vs >> x;
        REQUIRE(bool(vs));
        cam.fov_y = std::strtof(crosscheck::meta_get(meta, "fov_y").c_str(), nullptr);
        cam.z_near = std::strtof(crosscheck::meta_get(meta, "near").c_str(), nullptr);
        cam.z_far = std::strtof(crosscheck::meta_get(meta, "far").c_str(), nullptr);
        cam.width = uint32_t(std::strtoul(crosscheck::meta_get(meta, "width").c_str(), nullptr, 10));
        cam.height = uint32_t(std::strtoul(crosscheck::meta_get(meta, "height").c_str(), nullptr, 10));
    }
    const float epsilon = std::strtof(crosscheck::meta_get(meta, "epsilon").c_str(), nullptr);
    const double diameter = crosscheck::diameter(mesh);
    const unsigned nt = hardware_threads();
    std::printf("crosscheck %s: scene %s, %zu triangles, diameter %.3f, %ux%u, epsilon %g\n", dir.c_str(),
                crosscheck::meta_get(meta, "scene").c_str(), mesh.triangle_count(), diameter, cam.width, cam.height,
                double(epsilon));

    scene::Device dev("threads=1");
    const scene::Scene sc(dev.device, {&mesh});
    View v(cam);
    v.render(sc.scene, nt);

    Rays r;
    r.tmin = epsilon;
    for (uint32_t i = 0; i < set.reflection_count; ++i) {
        const crosscheck::Ray& q = set.rays[i];
        r.ray.push_back({{q.o[0], q.o[1], q.o[2]}, {q.d[0], q.d[1], q.d[2]}});
        CHECK(q.tmin == epsilon);
    }
    finish_rays(r, v, sc.scene, diameter, nt);
    CHECK(r.size() > 1000);
    CHECK(r.visible_count() > r.size() / 10);
    run_kernels("room (crosscheck)", v, sc.scene, r, diameter, nullptr);
}

// ---------------------------------------------------------------------------
// The own scene: a mirror floor (geometry 0), three walls, boxes and spheres
// tessellated with `n` rings (2n segments) each.

std::vector<scene::Mesh> own_meshes(int n) {
    std::vector<scene::Mesh> m;
    m.push_back(scene::quad({-8, 0, 4}, {8, 0, 4}, {8, 0, -12}, {-8, 0, -12}));     // mirror floor
    m.push_back(scene::quad({-8, 0, -12}, {8, 0, -12}, {8, 6, -12}, {-8, 6, -12}));  // back wall
    m.push_back(scene::quad({-8, 0, 4}, {-8, 0, -12}, {-8, 6, -12}, {-8, 6, 4}));    // left wall
    m.push_back(scene::quad({8, 0, -12}, {8, 0, 4}, {8, 6, 4}, {8, 6, -12}));        // right wall
    m.push_back(scene::box({-2.2, 0.75, -4.0}, {0.75, 0.75, 0.75}, 0.4));
    m.push_back(scene::box({2.8, 1.2, -6.5}, {0.6, 1.2, 0.6}, -0.3));
    m.push_back(scene::box({0.4, 0.35, -1.2}, {0.35, 0.35, 0.35}, 0.8));
    m.push_back(scene::sphere({0.9, 1.0, -3.6}, 1.0, n, 2 * n));
    m.push_back(scene::sphere({-3.8, 1.5, -8.5}, 1.5, n, 2 * n));
    m.push_back(scene::sphere({3.4, 0.6, -2.4}, 0.6, n, 2 * n));
    m.push_back(scene::sphere({-0.8, 2.6, -6.5}, 0.7, n, 2 * n));  // hovering
    return m;
}

size_t triangles(const std::vector<scene::Mesh>& m) {
    size_t t = 0;
    for (const auto& x : m) t += x.triangle_count();
    return t;
}

double meshes_diameter(const std::vector<scene::Mesh>& m) {
    double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
    for (const auto& x : m)
        for (size_t i = 0; i < x.vertices.size(); ++i) {
            lo[i % 3] = std::min(lo[i % 3], double(x.vertices[i]));
            hi[i % 3] = std::max(hi[i % 3], double(x.vertices[i]));
        }
    return std::sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                     (hi[2] - lo[2]) * (hi[2] - lo[2]));
}

// Rings per sphere for about `target` triangles in the whole own scene.
int rings_for(size_t target) { return std::max(4, int(std::lround(std::sqrt(double(target) / 16.0)))); }

refl_camera own_camera() {
    refl_camera cam{};
    REQUIRE(refl_camera_look_at(&cam, {0.0f, 2.2f, 5.0f}, {0.0f, 0.9f, -4.0f}, {0.0f, 1.0f, 0.0f}, 1.0f, 0.05f, 60.0f,
                                512, 384) == REFL_STATUS_OK);
    return cam;
}

// One reflection ray per mirror-floor pixel: the primary ray's exact hit
// with the plane y = 0 and its mirror direction, in double.
Rays mirror_rays(const View& v, RTCScene s, double diameter, unsigned threads) {
    Rays r;
    r.tmin = float(1e-5 * diameter);
    const float o[3] = {float(v.eye.x), float(v.eye.y), float(v.eye.z)};
    for (uint32_t y = 0; y < v.h; ++y)
        for (uint32_t x = 0; x < v.w; ++x) {
            const V3 d = v.primary_dir(x, y);
            const float fd[3] = {float(d.x), float(d.y), float(d.z)};
            const scene::Hit h = scene::trace(s, o, fd, 0.0f);
            if (!h.hit() || h.geom != 0 || !(d.y < 0.0)) continue;
            const double t = -v.eye.y / d.y;
            const V3 p = v.eye + t * d;
            r.ray.push_back({rv(p), rv(normalize({d.x, -d.y, d.z}))});
        }
    finish_rays(r, v, s, diameter, threads);
    return r;
}

// Long rays: from halfway along the primary ray of pixel (x, y) toward the
// surface seen through pixel (x + w/2 + 16 + k, h - 1 - y), k in [0, w/8),
// for a grid of pixels in the left quarter with a surface under both ends
// (projected walks of about 270 to 450 px, unless something nearer is hit).
std::vector<refl_ray> synthetic_long_rays(const View& v) {
    std::vector<refl_ray> out;
    for (uint32_t y = v.h / 8; y < v.h * 7 / 8; y += 4)
        for (uint32_t x = 4; x < v.w / 4; x += 4) {
            const uint32_t x2 = x + v.w / 2 + 16 + (7 * x + 13 * y) % (v.w / 8), y2 = v.h - 1 - y;
            if (x2 >= v.w) continue;
            const double za = v.lin[size_t(y) * v.w + x], zb = v.lin[size_t(y2) * v.w + x2];
            if (!std::isfinite(za) || !std::isfinite(zb)) continue;
            const V3 da = v.primary_dir(x, y), db = v.primary_dir(x2, y2);
            const V3 a = v.eye + (0.5 * za / v.view_forward(da)) * da;
            const V3 b = v.eye + (zb / v.view_forward(db)) * db;
            out.push_back({rv(a), rv(normalize(b - a))});
        }
    return out;
}

void run_own(const std::vector<size_t>& growth, size_t main_target) {
    const unsigned nt = hardware_threads();
    const refl_camera cam = own_camera();
    {
        const std::vector<scene::Mesh> meshes = own_meshes(rings_for(main_target));
        std::vector<const scene::Mesh*> ptrs;
        for (const auto& m : meshes) ptrs.push_back(&m);
        const double diameter = meshes_diameter(meshes);
        scene::Device dev("threads=1");
        const scene::Scene sc(dev.device, ptrs);
        View v(cam);
        v.render(sc.scene, nt);
        const Rays r = mirror_rays(v, sc.scene, diameter, nt);
        const std::vector<refl_ray> long_set = synthetic_long_rays(v);
        std::printf("own scene: %zu triangles, diameter %.3f, %ux%u, %zu mirror pixels, %zu synthetic long rays\n",
                    triangles(meshes), diameter, v.w, v.h, r.size(), long_set.size());
        CHECK(r.size() > 1000);
        CHECK(r.visible_count() > r.size() / 10);
        CHECK(long_set.size() > 500);
        run_kernels("own scene (mirror floor)", v, sc.scene, r, diameter, &long_set);
    }

    // Cost growth with the triangle count.
    std::printf("\n== cost growth, own scene, reversed-Z (infinite far), 1 thread everywhere (Embree device "
                "threads=1, build quality high) ==\n");
    std::printf("  refl times exclude rendering the depth buffer (Embree, not timed); hiz = pyramid build + trace "
                "per ray listed apart\n");
    std::printf("  %9s %7s | %12s %10s | %10s %10s %10s %12s | %8s %8s\n", "triangles", "rays", "embree build",
                "embree", "step s1", "hiz trace", "hiz build", "hiz b+t", "hit s1", "hit hiz");
    std::printf("  %9s %7s | %12s %10s | %10s %10s %10s %12s | %8s %8s\n", "", "", "ms", "ns/ray", "ns/ray", "ns/ray",
                "ms", "ns/ray", "", "");
    const std::vector<Kernel> ks = kernels();
    for (size_t target : growth) {
        const std::vector<scene::Mesh> meshes = own_meshes(rings_for(target));
        std::vector<const scene::Mesh*> ptrs;
        for (const auto& m : meshes) ptrs.push_back(&m);
        const double diameter = meshes_diameter(meshes);
        scene::Device dev("threads=1");
        const auto t0 = Clock::now();
        const scene::Scene sc(dev.device, ptrs);
        const double build_ms = ms_since(t0);
        View v(cam);
        v.render(sc.scene, nt);
        const Rays r = mirror_rays(v, sc.scene, diameter, nt);
        const double e1 = embree_ns(sc.scene, r, 1);
        const DepthBuf db = encode(v, REFL_DEPTH_CONVENTION_REVERSED_Z);
        const Pyramid pyr = build_pyramid(db, 1);
        Target t;
        t.image = db.image();
        t.hiz = {pyr.data.data(), pyr.data.size(), db.cam, db.conv};
        t.thickness.constant = float(kThicknessOfDiameter * diameter);
        t.thickness.back_faces = refl_image_f32{nullptr, 0, 0, 0, 0};
        std::vector<refl_trace_result> out;
        bool ok = true;
        const double s1 = median_seconds(kTimingRuns, [&] { ok &= trace_all(ks[0], t, r.screen, out, 1); });
        const Stats st_s = evaluate(r, out);
        const double h1 = median_seconds(kTimingRuns, [&] { ok &= trace_all(ks[3], t, r.screen, out, 1); });
        const Stats st_h = evaluate(r, out);
        CHECK(ok);
        CHECK(st_s.nan == 0 && st_h.nan == 0);
        const double n = double(std::max<size_t>(r.size(), 1));
        std::printf("  %9zu %7zu | %12.1f %10.1f | %10.1f %10.1f %10.2f %12.1f | %8.4f %8.4f\n", triangles(meshes),
                    r.size(), build_ms, e1, s1 * 1e9 / n, h1 * 1e9 / n, pyr.build_ms,
                    (h1 + pyr.build_ms * 1e-3) * 1e9 / n, st_s.hit_rate(), st_h.hit_rate());
    }
}

}  // namespace

int main(int argc, char** argv) {
    scene::set_ftz_daz();
    if (argc > 2) crosscheck::die("usage: depth_image_embree [dir written by `refl export-crosscheck`]");
    if (argc == 2) {
        run_crosscheck(argv[1]);
        return check::finish("depth_image_embree (crosscheck)");
    }
    if (kSanitized) run_own({10000, 100000}, 10000);
    else run_own({10000, 100000, 1000000}, 100000);
    return check::finish("depth_image_embree (own scene)");
}
