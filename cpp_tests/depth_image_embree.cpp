// depth_image_embree: refl's screen-space mirror pass (refl_ssr_*: per-pixel
// stepping and Hi-Z traversal behind the pass's own ray generation, start
// rule, thickness and hit validation) through the C ABI against Embree 3
// (rtcIntersect1) on the same reflections, plus the bare kernels
// (refl_step_rays, refl_hiz_*) on synthetic long rays.
//
// Usage:
//     depth_image_embree            the harness's own scene (built here)
//     depth_image_embree <dir>      the room scene of a directory written by
//                                   `refl export-crosscheck` (crosscheck.hpp)
//
// Per scene:
//  * Embree renders the primary view's G-buffer: one primary ray per pixel
//    center (src/export.rs crosscheck_rays: computed in double, cast once),
//    linear depth z = t * (-dir_view.z) (nothing hit: the far plane) and
//    the geometric normal facing the eye. refl_camera_encode_depth stores
//    the depth in the three conventions: Linear and ZeroToOne with the
//    camera's far plane, ReversedZ with an infinite one.
//  * Reflections (the reference, evaluation only): the crosscheck's (the
//    first reflection_count rays of rays.bin, on a surface, tmin = epsilon;
//    each belongs to the pixel its origin projects to) or, for the own
//    scene, one per mirror-floor pixel (exact plane hit and mirror
//    direction in double). The reference is rtcIntersect1 of these rays.
//    The G-buffer's reflective mask holds those pixels, and their normal is
//    the one the reference reflects about (the crosscheck's shading normal,
//    recovered as normalize(r - d) from the primary direction d and the
//    reflection r; the floor's +Y), so that the pass's rays are the same
//    reflections.
//  * Visible: the reference hit projects into the image and Embree's primary
//    depth at that pixel is within 2% (relative) of the hit's linear depth.
//    Found: a pass hit (REFL_SSR_STATUS_HIT) within 1 px (Euclidean) of the
//    reference hit's projection. False hit: a hit on a ray whose reference
//    is not visible. (src/screen.rs evaluates the same way.)
//  * Pass settings: refl_ssr_options_default (stride-1 stepping) and
//    strides 4 and 16; Hi-Z with its default options and three variants;
//    stride 1 and default Hi-Z again with refine off; every convention.
//    refl_ssr_prepare (the Hi-Z pyramid) and refl_ssr_trace_rows are timed
//    apart, the rows on one thread and split into bands on all hardware
//    threads (std::thread), next to rtcIntersect1 on the reference rays.
//
// Checks (correctness only, never time): every status OK, every texel
// finite, every reflective pixel traced and every pixel the pass hands to
// the host listed; for stride 1 and every Hi-Z setting in every
// convention: found >= 0.95 of the visible reflections and false hits on
// at most kMaxFalse of the rays whose reflection is not visible (refined);
// Hi-Z agrees with stride-1 stepping (both without a hit, or both hit
// within one pixel) on >= 99% of the pixels; the pyramid refl_ssr_prepare
// builds is bit-identical to refl_hiz_build's and to a multi-threaded
// row-band build (refl_hiz_build_rows). Own scene only: on a synthetic set
// of long rays (projected walk > 256 px) the bare kernels' unit-step /
// Hi-Z fetch ratio is >= 10 in every convention, and Hi-Z agrees with
// stepping on >= 99% of them. The own scene also prints the cost growth at
// about 10k, 100k and 1M triangles (Embree BVH build, rtcIntersect1 and
// rtcIntersect8 over 4x2-pixel packets vs. the pass per ray; the G-buffer
// rendering is excluded from every refl time; the packets' hits are checked
// against rtcIntersect1's), and the bare Hi-Z kernel (refl_hiz_trace_rays,
// the AVX2 ray stream where the CPU has it; iterations and fetches per ray,
// lanes) against Embree on the same rays (the pass's reflection rays
// lifted off the mirror floor; >= 90% of the visible reflections found
// within 1.5 px of Embree's hit), then one line per ratio for scripts:
// `ratio hiz_vs_embree1_1t V` (and `hiz_vs_embree8`, `step_vs_embree1`,
// `hiz_kernel_vs_embree1`, `hiz_kernel_vs_embree8`; the same with `_1t_1m`
// at 1M triangles), V = refl's rays per second over Embree's on one thread
// (above 1: refl is faster).
#include <embree3/rtcore.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <mutex>
#include <string>
#include <thread>
#include <tuple>
#include <utility>
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

// src/screen.rs: VISIBLE_DEPTH_TOLERANCE, FOUND_RADIUS_PX (evaluation).
constexpr double kVisibleTolerance = 0.02;
constexpr double kFoundRadiusPx = 1.0;
// The bare kernels on the synthetic long rays: a constant thickness of
// 0.005 scene diameters.
constexpr double kThicknessOfDiameter = 0.005;
constexpr double kLongRayPx = 256.0;
constexpr int kTimingRuns = 3;
constexpr float kInf = std::numeric_limits<float>::infinity();
// Most false hits allowed (share of the rays whose reflection is not
// visible) for stride 1 and Hi-Z with refinement.
constexpr double kMaxFalse = 0.05;

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

// rtcIntersect1 returning the geometric normal and geometry as well.
struct NgHit {
    bool hit = false;
    float t = kInf;
    unsigned geom = RTC_INVALID_GEOMETRY_ID;
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
        h.geom = rh.hit.geomID;
        h.ng = {rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z};
    }
    return h;
}

// The primary view: refl cameras (far plane finite, and infinite for
// reversed-Z), the double-precision ray formula of src/export.rs and
// Embree's G-buffer (linear depth, geometric normal facing the eye,
// geometry id).
struct View {
    refl_camera cam{}, cam_inf{};
    double inv[16] = {}, view[16] = {};
    double tan_x = 0, tan_y = 0;
    uint32_t w = 0, h = 0;
    V3 eye{0, 0, 0};
    std::vector<double> lin;          // linear depth per pixel, +inf: nothing hit
    std::vector<refl_vec3> normal;    // geometric normal facing the eye, 0: nothing hit
    std::vector<unsigned> geom;       // geometry id, RTC_INVALID_GEOMETRY_ID: nothing hit

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

    void render(RTCScene s, unsigned threads) {
        const size_t n = size_t(w) * h;
        lin.assign(n, std::numeric_limits<double>::infinity());
        normal.assign(n, refl_vec3{0.0f, 0.0f, 0.0f});
        geom.assign(n, RTC_INVALID_GEOMETRY_ID);
        const float o[3] = {float(eye.x), float(eye.y), float(eye.z)};
        parallel_for(h, threads, [&](size_t y0, size_t y1) {
            for (size_t y = y0; y < y1; ++y)
                for (uint32_t x = 0; x < w; ++x) {
                    const V3 dd = primary_dir(x, uint32_t(y));
                    const float d[3] = {float(dd.x), float(dd.y), float(dd.z)};
                    const NgHit hh = trace_ng(s, o, d, 0.0f, kInf);
                    if (!hh.hit) continue;
                    const size_t i = y * w + x;
                    lin[i] = double(hh.t) * view_forward({d[0], d[1], d[2]});
                    geom[i] = hh.geom;
                    if (scene::length(hh.ng) > 0.0) {
                        V3 ng = normalize(hh.ng);
                        if (scene::dot(ng, dd) > 0.0) ng = -1.0 * ng;
                        normal[i] = rv(ng);
                    }
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

// The reference reflections (one per reflective pixel) with their hits.
struct Rays {
    std::vector<refl_ray> ray;     // origin on the surface
    std::vector<uint32_t> pixel;   // y * width + x of the pixel the ray reflects
    float tmin = 0.0f;
    std::vector<uint8_t> ref_hit, visible;
    std::vector<float> ref_px, ref_py;  // projection of the reference hit
    size_t size() const { return ray.size(); }
    size_t visible_count() const { return size_t(std::count(visible.begin(), visible.end(), 1)); }
};

// Fills reference hits, projections and visibility of r.ray.
void finish_rays(Rays& r, const View& v, RTCScene s, unsigned threads) {
    const size_t n = r.size();
    r.ref_hit.assign(n, 0);
    r.visible.assign(n, 0);
    r.ref_px.assign(n, 0.0f);
    r.ref_py.assign(n, 0.0f);
    std::atomic<size_t> bad_status{0};
    parallel_for(n, threads, [&](size_t b, size_t e) {
        for (size_t i = b; i < e; ++i) {
            const refl_ray& q = r.ray[i];
            const V3 o = dv(q.origin), d = dv(q.dir);
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
            r.ref_px[i] = p.x;
            r.ref_py[i] = p.y;
            if (!(p.x >= 0.0f && p.y >= 0.0f && p.x < float(v.w) && p.y < float(v.h))) continue;
            const double z = v.lin[size_t(p.y) * v.w + size_t(p.x)];
            r.visible[i] = std::isfinite(z) && std::fabs(z - double(p.depth)) <= kVisibleTolerance * double(p.depth);
        }
    });
    CHECK(bad_status == 0);
}

// The pass's G-buffer of a view: Embree's normals, except that every pixel
// with a reference reflection gets the normal the reference reflects about
// (normalize(r - d), d the pixel's primary direction), and the mask of
// those pixels; one depth buffer per convention.
struct Frame {
    std::vector<refl_vec3> normals;
    std::vector<uint8_t> mask;
    std::vector<DepthBuf> depth;  // kConventions order
    refl_gbuffer gbuffer(size_t k) const {
        const DepthBuf& d = depth[k];
        const uint32_t w = d.cam.width, h = d.cam.height;
        const size_t n = size_t(w) * h;
        refl_gbuffer g{};
        g.depth = d.image();
        g.normals = {normals.data(), n, w, h, w};
        g.normal_space = REFL_NORMAL_SPACE_WORLD;
        g.mask = {mask.data(), n, w, h, w};
        return g;
    }
};

Frame make_frame(const View& v, const Rays& r) {
    Frame f;
    f.normals = v.normal;
    f.mask.assign(v.normal.size(), 0);
    for (size_t i = 0; i < r.size(); ++i) {
        const uint32_t p = r.pixel[i];
        const V3 d = v.primary_dir(p % v.w, p / v.w), n = dv(r.ray[i].dir) - d;
        CHECK(f.mask[p] == 0);  // one reflection per pixel
        f.mask[p] = 1;
        if (scene::length(n) > 0.0) f.normals[p] = rv(normalize(n));
    }
    for (uint32_t c : kConventions) f.depth.push_back(encode(v, c));
    return f;
}

// A pass setting.
struct Setting {
    std::string kind, name;
    refl_ssr_options opt{};
    bool hiz() const { return opt.method == REFL_SSR_METHOD_HIZ; }
    bool checked() const { return opt.refine && (hiz() || opt.step.stride == 1); }
};

std::vector<Setting> settings() {
    std::vector<Setting> k;
    const refl_ssr_options def = refl_ssr_options_default();
    for (uint32_t s : {1u, 4u, 16u}) {
        Setting x{"step", "stride " + std::to_string(s), def};
        x.opt.method = REFL_SSR_METHOD_STEP;
        x.opt.step.stride = s;
        k.push_back(x);
    }
    const refl_hiz_options hd = refl_hiz_options_default();
    auto hiz = [&](const std::string& name, refl_hiz_options o) {
        Setting x{"hiz", name, def};
        x.opt.method = REFL_SSR_METHOD_HIZ;
        x.opt.hiz = o;
        k.push_back(x);
    };
    hiz("default (s" + std::to_string(hd.start_level) + " e" + std::to_string(hd.stop_level) + " p" +
            std::to_string(hd.prologue_steps) + ")",
        hd);
    refl_hiz_options o = hd;
    o.start_level = 0;
    o.prologue_steps = 0;
    hiz("start 0, no prologue", o);
    o = hd;
    o.start_level = 5;
    hiz("start 5", o);
    o = hd;
    o.stop_level = 2;
    hiz("stop 2", o);
    // Stride 1 and the default Hi-Z without sub-texel refinement.
    Setting r1 = k[0];
    r1.name += ", refine off";
    r1.opt.refine = false;
    k.push_back(r1);
    Setting r2 = k[3];
    r2.name += ", refine off";
    r2.opt.refine = false;
    k.push_back(r2);
    return k;
}

// The pass's output over a whole image.
struct PassOut {
    std::vector<refl_ssr_texel> texel;
    refl_ssr_stats stats{};
    size_t host_listed = 0;  // host rays written whose status needs the host
    bool ok = true;
};

bool needs_host(uint32_t s) {
    return s == REFL_SSR_STATUS_LEFT_IMAGE || s == REFL_SSR_STATUS_BEHIND_GEOMETRY ||
           s == REFL_SSR_STATUS_OUT_OF_STEPS || s == REFL_SSR_STATUS_NO_PROJECTION ||
           s == REFL_SSR_STATUS_BACK_FACE || s == REFL_SSR_STATUS_HIDDEN;
}

// refl_ssr_trace_rows over every row, split into one band per thread, each
// with its own host list (as large as its band).
PassOut trace_pass(const refl_gbuffer& gb, const refl_ssr_options& o, const std::vector<refl_vec2>& scratch,
                   unsigned threads) {
    const uint32_t w = gb.depth.camera.width, h = gb.depth.camera.height;
    PassOut out;
    out.texel.assign(size_t(w) * h, refl_ssr_texel{});
    std::mutex m;
    parallel_for(h, threads, [&](size_t b, size_t e) {
        std::vector<refl_host_ray> host((e - b) * w);
        refl_ssr_stats st{};
        const refl_status s =
            refl_ssr_trace_rows(&st, out.texel.data(), out.texel.size(), refl_image_vec3_mut{nullptr, 0, 0, 0, 0},
                                host.data(), host.size(), &gb, &o, scratch.empty() ? nullptr : scratch.data(),
                                scratch.size(), refl_row_range{uint32_t(b), uint32_t(e)});
        size_t listed = 0;
        for (uint32_t k = 0; k < st.host_rays_written; ++k) {
            const refl_host_ray& r = host[k];
            listed += r.y >= b && r.y < e && needs_host(r.status) &&
                      out.texel[size_t(r.y) * w + r.x].status == r.status;
        }
        std::lock_guard<std::mutex> lock(m);
        out.ok = out.ok && s == REFL_STATUS_OK && st.host_rays_written == st.host_rays;
        out.stats.traced += st.traced;
        out.stats.hits += st.hits;
        out.stats.sky += st.sky;
        out.stats.host_rays += st.host_rays;
        out.stats.host_rays_written += st.host_rays_written;
        out.host_listed += listed;
    });
    return out;
}

bool finite_texel(const refl_ssr_texel& t) {
    return std::isfinite(t.pixel.x) && std::isfinite(t.pixel.y) && std::isfinite(t.t) && std::isfinite(t.confidence);
}

struct Stats {
    size_t rays = 0, visible = 0, found = 0, wrong = 0, missed = 0, false_hits = 0, nan = 0, host = 0, err_n = 0;
    double err_sum = 0.0;
    double hit_rate() const { return visible ? double(found) / double(visible) : 0.0; }
    double false_rate() const { return rays > visible ? double(false_hits) / double(rays - visible) : 0.0; }
};

Stats evaluate(const Rays& r, const PassOut& p) {
    Stats s;
    s.rays = r.size();
    for (const auto& t : p.texel) s.nan += !finite_texel(t);
    for (size_t i = 0; i < r.size(); ++i) {
        const refl_ssr_texel& t = p.texel[r.pixel[i]];
        s.host += needs_host(t.status);
        const bool hit = t.status == REFL_SSR_STATUS_HIT, vis = r.visible[i] != 0;
        s.visible += vis;
        if (hit && vis) {
            const double err = std::hypot(double(t.pixel.x) - r.ref_px[i], double(t.pixel.y) - r.ref_py[i]);
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

// Both without a hit, or both hit within one pixel of each other, over the
// reflective pixels.
double agreement(const Rays& r, const PassOut& a, const PassOut& b) {
    size_t n = 0;
    for (uint32_t p : r.pixel) {
        const refl_ssr_texel &x = a.texel[p], &y = b.texel[p];
        const bool hx = x.status == REFL_SSR_STATUS_HIT, hy = y.status == REFL_SSR_STATUS_HIT;
        n += hx == hy && (!hx || std::hypot(double(x.pixel.x) - y.pixel.x, double(x.pixel.y) - y.pixel.y) <= 1.0);
    }
    return r.size() ? double(n) / double(r.size()) : 1.0;
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

// The rays regrouped for Embree's 8-ray packets: ordered by 4x2 pixel
// tiles (`width` the image's), so that a packet holds the coherent rays of
// neighboring pixels, in structure-of-arrays-friendly flat arrays.
struct Packets {
    std::vector<float> org, dir;     // 3 floats per ray, tile order
    std::vector<size_t> index;       // index into Rays of each
    size_t size() const { return index.size(); }
};

Packets packets(const Rays& r, uint32_t width) {
    Packets p;
    p.index.resize(r.size());
    for (size_t i = 0; i < r.size(); ++i) p.index[i] = i;
    auto key = [&](size_t i) {
        const uint32_t x = r.pixel[i] % width, y = r.pixel[i] / width;
        return std::make_tuple(y / 2, x / 4, y, x);
    };
    std::stable_sort(p.index.begin(), p.index.end(), [&](size_t a, size_t b) { return key(a) < key(b); });
    for (size_t i : p.index) {
        const refl_ray& q = r.ray[i];
        p.org.insert(p.org.end(), {q.origin.x, q.origin.y, q.origin.z});
        p.dir.insert(p.dir.end(), {q.dir.x, q.dir.y, q.dir.z});
    }
    return p;
}

// Embree's rtcIntersect8 over the packets (8 consecutive rays in tile
// order), ns per ray, median of kTimingRuns, one thread. The hits are
// checked against rtcIntersect1's (same primitive, or the same t within
// 1e-5 relative where two triangles share the hit point).
double embree8_ns(RTCScene s, const Rays& r, const Packets& p) {
    scene::Hit hits[8];
    for (size_t b = 0; b < p.size(); b += 8) {
        const size_t n = std::min<size_t>(8, p.size() - b);
        scene::trace8(s, &p.org[3 * b], &p.dir[3 * b], n, r.tmin, hits);
        for (size_t k = 0; k < n; ++k) {
            const scene::Hit one = scene::trace(s, &p.org[3 * (b + k)], &p.dir[3 * (b + k)], r.tmin);
            CHECK(one.hit() == hits[k].hit());
            if (one.hit() && hits[k].hit() && one.prim != hits[k].prim)
                CHECK(std::fabs(one.t - hits[k].t) <= 1e-5f * std::max(1.0f, one.t));
        }
    }
    float acc = 0.0f;
    const double secs = median_seconds(kTimingRuns, [&] {
        for (size_t b = 0; b < p.size(); b += 8) {
            scene::trace8(s, &p.org[3 * b], &p.dir[3 * b], std::min<size_t>(8, p.size() - b), r.tmin, hits);
            for (const scene::Hit& h : hits)
                if (h.hit()) acc += h.t;
        }
    });
    volatile float sink = acc;
    (void)sink;
    return r.size() ? secs * 1e9 / double(r.size()) : 0.0;
}

// The pass's scratch for a setting, prepared (timed, median); for Hi-Z the
// pyramid is checked bit-identical to refl_hiz_build's.
struct Prepared {
    std::vector<refl_vec2> scratch;
    double ms = 0.0;
    bool ok = true;
};

Prepared prepare(const refl_gbuffer& gb, const refl_ssr_options& o) {
    Prepared p;
    size_t len = 0;
    p.ok = refl_ssr_scratch_len(&len, &gb, &o) == REFL_STATUS_OK;
    p.scratch.assign(len, refl_vec2{0.0f, 0.0f});
    p.ms = 1e3 * median_seconds(kTimingRuns, [&] {
        p.ok = p.ok && refl_ssr_prepare(p.scratch.empty() ? nullptr : p.scratch.data(), p.scratch.size(), &gb, &o) ==
                           REFL_STATUS_OK;
    });
    if (o.method == REFL_SSR_METHOD_HIZ) {
        std::vector<refl_vec2> ref(len, refl_vec2{0.0f, 0.0f});
        CHECK_STATUS(refl_hiz_build(ref.data(), ref.size(), &gb.depth), REFL_STATUS_OK);
        CHECK(len > 0 && std::memcmp(ref.data(), p.scratch.data(), len * sizeof(refl_vec2)) == 0);
    }
    return p;
}

// refl_hiz_build against a multi-threaded row-band build (bit-identical).
void check_banded_pyramid(const DepthBuf& db, unsigned threads) {
    size_t len = 0;
    uint32_t levels = 0;
    REQUIRE(refl_hiz_len(&len, &levels, db.cam.width, db.cam.height) == REFL_STATUS_OK);
    const refl_depth_image im = db.image();
    std::vector<refl_vec2> whole(len, refl_vec2{0.0f, 0.0f}), bands(len, refl_vec2{0.0f, 0.0f});
    CHECK_STATUS(refl_hiz_build(whole.data(), whole.size(), &im), REFL_STATUS_OK);
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
    CHECK(std::memcmp(bands.data(), whole.data(), len * sizeof(refl_vec2)) == 0);
}

void print_header() {
    std::printf("  %-5s %-34s %-7s %7s %6s %7s %6s %6s %7s %6s %6s | %8s %8s %8s %8s %8s %6s %6s\n", "pass", "setting",
                "conv", "rays", "vis%", "found", "vmiss", "vwrong", "false", "errpx", "host%", "prep ms", "ns/r 1t",
                "ns/r Nt", "embr 1t", "embr Nt", "x 1t", "x Nt");
}

// The bare kernels (no pass) on the synthetic long rays.
struct Kernel {
    bool hiz = false;
    std::string name;
    refl_step_options step{1, UINT32_MAX};
    refl_hiz_options hopt{};
};

bool trace_bare(const Kernel& k, const refl_depth_image& im, const refl_hiz& hz, const refl_trace_thickness& th,
                const std::vector<refl_ray>& rays, std::vector<refl_trace_result>& out, unsigned threads) {
    out.resize(rays.size());
    std::atomic<size_t> bad{0};
    const float tmax = kInf;
    parallel_for(rays.size(), threads, [&](size_t b, size_t e) {
        const refl_status s =
            k.hiz ? refl_hiz_trace_rays(out.data() + b, e - b, &hz, &th, rays.data() + b, e - b, &tmax, 1, &k.hopt)
                  : refl_step_rays(out.data() + b, e - b, &im, &th, rays.data() + b, e - b, &tmax, 1, &k.step);
        if (s != REFL_STATUS_OK) ++bad;
    });
    return bad == 0;
}

bool finite_result(const refl_trace_result& r) {
    return std::isfinite(r.pixel.x) && std::isfinite(r.pixel.y) && std::isfinite(r.t) && std::isfinite(r.depth) &&
           std::isfinite(r.surface_depth);
}

// Both miss, or both hit within one pixel of each other.
bool same_hit(const refl_trace_result& a, const refl_trace_result& b) {
    const bool ha = a.miss == REFL_TRACE_MISS_NONE, hb = b.miss == REFL_TRACE_MISS_NONE;
    if (ha != hb) return false;
    return !ha || std::hypot(double(a.pixel.x) - b.pixel.x, double(a.pixel.y) - b.pixel.y) <= 1.0;
}

// Rays both kernels hit at the same place after walking more than
// kLongRayPx pixels from the projection of the ray's origin; their fetches.
struct LongRays {
    size_t n = 0, agree = 0;
    uint64_t step_fetches = 0, hiz_fetches = 0;
    double ratio() const { return hiz_fetches ? double(step_fetches) / double(hiz_fetches) : 0.0; }
};
LongRays long_rays(const View& v, const std::vector<refl_ray>& rays, const std::vector<refl_trace_result>& step,
                   const std::vector<refl_trace_result>& hiz) {
    LongRays l;
    for (size_t i = 0; i < rays.size(); ++i) {
        l.agree += same_hit(step[i], hiz[i]);
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

// The bare kernels on synthetic long rays in every convention: stride 1
// against Hi-Z settings (agreement and fetch ratio).
void run_long_rays(const View& v, const Frame& f, const std::vector<refl_ray>& set, double diameter) {
    const unsigned nt = hardware_threads();
    std::printf("  Long rays, bare kernels (synthetic: from halfway along a pixel's primary ray in the left quarter "
                "toward a surface %u to %u px to its right, mirrored in y; constant thickness %.4g):\n",
                v.w / 2 + 16, v.w / 2 + 16 + v.w / 8 - 1, kThicknessOfDiameter * diameter);
    const refl_hiz_options hd = refl_hiz_options_default();
    std::vector<Kernel> hiz_kernels;
    {
        Kernel k;
        k.hiz = true;
        k.name = "default";
        k.hopt = hd;
        hiz_kernels.push_back(k);
        k.name = "start 0, no prologue";
        k.hopt.start_level = 0;
        k.hopt.prologue_steps = 0;
        hiz_kernels.push_back(k);
        k.name = "stop 2";
        k.hopt = hd;
        k.hopt.stop_level = 2;
        hiz_kernels.push_back(k);
    }
    for (size_t c = 0; c < f.depth.size(); ++c) {
        const DepthBuf& db = f.depth[c];
        const refl_depth_image im = db.image();
        size_t len = 0;
        uint32_t levels = 0;
        REQUIRE(refl_hiz_len(&len, &levels, db.cam.width, db.cam.height) == REFL_STATUS_OK);
        std::vector<refl_vec2> pyr(len, refl_vec2{0.0f, 0.0f});
        CHECK_STATUS(refl_hiz_build(pyr.data(), pyr.size(), &im), REFL_STATUS_OK);
        const refl_hiz hz{pyr.data(), pyr.size(), db.cam, db.conv};
        refl_trace_thickness th{};
        th.constant = float(kThicknessOfDiameter * diameter);
        th.back_faces = refl_image_f32{nullptr, 0, 0, 0, 0};
        std::vector<refl_trace_result> a, b;
        CHECK(trace_bare(Kernel{}, im, hz, th, set, a, nt));
        for (const Kernel& k : hiz_kernels) {
            CHECK(trace_bare(k, im, hz, th, set, b, nt));
            size_t nan = 0;
            for (const auto& x : b) nan += !finite_result(x);
            CHECK(nan == 0);
            const LongRays l = long_rays(v, set, a, b);
            const double ag = set.empty() ? 1.0 : double(l.agree) / double(set.size());
            std::printf("  %-7s hiz %-24s %zu rays: agreement %.4f; long rays (> %.0f px) %zu: fetches/ray stride 1 "
                        "%.1f, hiz %.1f, ratio %.2f\n",
                        convention_name(db.conv), k.name.c_str(), set.size(), ag, kLongRayPx, l.n,
                        l.n ? double(l.step_fetches) / double(l.n) : 0.0,
                        l.n ? double(l.hiz_fetches) / double(l.n) : 0.0, l.ratio());
            CHECK(ag >= 0.99);
            CHECK(l.n >= set.size() / 4);
            if (k.name == "default") CHECK(l.ratio() >= 10.0);
        }
    }
}

// Runs every pass setting in every convention on the frame, prints the
// table and checks.
void run_pass(const char* title, RTCScene s, const Rays& r, const Frame& f) {
    const unsigned nt = hardware_threads();
    const double e1 = embree_ns(s, r, 1), en = embree_ns(s, r, nt);
    const size_t mask_pixels = size_t(std::count(f.mask.begin(), f.mask.end(), 1));
    std::printf("\n== %s: %zu reflections (reflective pixels), %zu visible (%.1f%%); refl_ssr_options_default "
                "(thickness %.2g of the pixel's depth, start after %.2g px); %u threads ==\n",
                title, r.size(), r.visible_count(), r.size() ? 100.0 * double(r.visible_count()) / double(r.size()) : 0.0,
                double(refl_ssr_options_default().thickness), double(refl_ssr_options_default().start_pixels), nt);
    CHECK(mask_pixels == r.size());
    print_header();
    const std::vector<Setting> ks = settings();
    std::vector<std::string> agree_lines;
    for (size_t c = 0; c < f.depth.size(); ++c) {
        const refl_gbuffer gb = f.gbuffer(c);
        const uint32_t conv = f.depth[c].conv;
        check_banded_pyramid(f.depth[c], nt);
        PassOut step1;
        for (const Setting& k : ks) {
            const Prepared prep = prepare(gb, k.opt);
            CHECK(prep.ok);
            PassOut out;
            const double t1 = median_seconds(kTimingRuns, [&] { out = trace_pass(gb, k.opt, prep.scratch, 1); });
            CHECK(out.ok);
            const double tn = median_seconds(kTimingRuns, [&] { out = trace_pass(gb, k.opt, prep.scratch, nt); });
            CHECK(out.ok);
            const Stats st = evaluate(r, out);
            const double n1 = r.size() ? t1 * 1e9 / double(r.size()) : 0.0;
            const double nn = r.size() ? tn * 1e9 / double(r.size()) : 0.0;
            std::printf("  %-5s %-34s %-7s %7zu %6.1f %7.4f %6zu %6zu %7.4f %6.3f %6.1f | %8.2f %8.1f %8.1f %8.1f "
                        "%8.1f %6.2f %6.2f\n",
                        k.kind.c_str(), k.name.c_str(), convention_name(conv), st.rays,
                        st.rays ? 100.0 * double(st.visible) / double(st.rays) : 0.0, st.hit_rate(), st.missed,
                        st.wrong, st.false_rate(), st.err_n ? st.err_sum / double(st.err_n) : 0.0,
                        st.rays ? 100.0 * double(st.host) / double(st.rays) : 0.0, prep.ms, n1, nn, e1, en,
                        e1 > 0 ? n1 / e1 : 0.0, en > 0 ? nn / en : 0.0);
            CHECK(st.nan == 0);
            // Every reflective pixel has a surface and is traced; every
            // pixel the pass hands to the host is in a host list.
            CHECK(out.stats.traced == r.size());
            CHECK(out.host_listed == out.stats.host_rays && out.stats.host_rays == st.host);
            if (k.checked()) {
                // The bounds are on visible rays; a scene without any would make them vacuous.
                CHECK(st.visible > 0);
                if (!(st.hit_rate() >= 0.95 && st.false_rate() <= kMaxFalse))
                    std::fprintf(stderr, "found %.4f < 0.95 or false hits %.4f > %.2f: %s %s %s\n", st.hit_rate(),
                                 st.false_rate(), kMaxFalse, k.kind.c_str(), k.name.c_str(), convention_name(conv));
                CHECK(st.hit_rate() >= 0.95);
                CHECK(st.false_rate() <= kMaxFalse);
            }
            if (!k.hiz() && k.opt.step.stride == 1 && k.opt.refine) {
                // Why visible reflections were not found: the status.
                size_t why[16] = {};
                for (size_t i = 0; i < r.size(); ++i)
                    if (r.visible[i] && out.texel[r.pixel[i]].status != REFL_SSR_STATUS_HIT)
                        ++why[std::min<uint32_t>(out.texel[r.pixel[i]].status, 15)];
                std::printf("        visible, not hit, by refl_ssr_status:");
                for (int w = 0; w < 16; ++w)
                    if (why[w]) std::printf(" %d: %zu", w, why[w]);
                std::printf("\n");
                step1 = out;
            } else if (k.hiz()) {
                const double a = agreement(r, step1, out);
                char line[256];
                std::snprintf(line, sizeof line, "  %-7s %-34s agrees with stride 1 on %.4f of %zu pixels",
                              convention_name(conv), k.name.c_str(), a, r.size());
                agree_lines.push_back(line);
                if (k.opt.refine) CHECK(a >= 0.99);
            }
        }
    }
    std::printf("  Hi-Z vs stride-1 stepping (the pass with each; both without a hit or both hit within 1 px):\n");
    for (const auto& l : agree_lines) std::printf("%s\n", l.c_str());
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

    // Each reflection belongs to the pixel its origin (the pixel center's
    // primary hit) projects to.
    Rays r;
    r.tmin = epsilon;
    for (uint32_t i = 0; i < set.reflection_count; ++i) {
        const crosscheck::Ray& q = set.rays[i];
        CHECK(q.tmin == epsilon);
        refl_projection p{};
        const refl_vec3 o{q.o[0], q.o[1], q.o[2]};
        if (refl_camera_project(&p, &v.cam, o) != REFL_STATUS_OK || !p.valid || !(p.x >= 0.0f && p.y >= 0.0f) ||
            !(p.x < float(v.w) && p.y < float(v.h))) {
            CHECK(false);
            continue;
        }
        r.ray.push_back({o, {q.d[0], q.d[1], q.d[2]}});
        r.pixel.push_back(uint32_t(p.y) * v.w + uint32_t(p.x));
    }
    finish_rays(r, v, sc.scene, nt);
    CHECK(r.size() > 1000);
    CHECK(r.visible_count() > r.size() / 10);
    const Frame f = make_frame(v, r);
    run_pass("room (crosscheck)", sc.scene, r, f);
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

// One reflection per mirror-floor pixel: the primary ray's exact hit with
// the plane y = 0 and its mirror direction, in double.
Rays mirror_rays(const View& v, RTCScene s, double diameter, unsigned threads) {
    Rays r;
    r.tmin = float(1e-5 * diameter);
    for (uint32_t y = 0; y < v.h; ++y)
        for (uint32_t x = 0; x < v.w; ++x) {
            const size_t i = size_t(y) * v.w + x;
            const V3 d = v.primary_dir(x, y);
            if (v.geom[i] != 0 || !(d.y < 0.0)) continue;
            const double t = -v.eye.y / d.y;
            const V3 p = v.eye + t * d;
            r.ray.push_back({rv(p), rv(normalize({d.x, -d.y, d.z}))});
            r.pixel.push_back(uint32_t(i));
        }
    finish_rays(r, v, s, threads);
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
        const Frame f = make_frame(v, r);
        run_pass("own scene (mirror floor)", sc.scene, r, f);
        run_long_rays(v, f, long_set, diameter);
    }

    // Cost growth with the triangle count.
    std::printf("\n== cost growth, own scene, reversed-Z (infinite far), 1 thread everywhere (Embree device "
                "threads=1, build quality high) ==\n");
    std::printf("  refl times exclude rendering the G-buffer (Embree, not timed); the pass's prepare (the Hi-Z "
                "pyramid) is listed apart\n");
    std::printf("  %9s %7s | %12s %10s %10s | %10s %10s %10s %12s | %8s %8s\n", "triangles", "rays", "embree build",
                "embree x1", "embree x8", "step s1", "hiz trace", "hiz prep", "hiz p+t", "found s1", "found hz");
    std::printf("  %9s %7s | %12s %10s %10s | %10s %10s %10s %12s | %8s %8s\n", "", "", "ms", "ns/ray", "ns/ray",
                "ns/ray", "ns/ray", "ms", "ns/ray", "", "");
    std::vector<std::string> ratio_lines, kernel_lines;
    const std::vector<Setting> ks = settings();
    for (size_t target : growth) {
        const std::vector<scene::Mesh> meshes = own_meshes(rings_for(target));
        std::vector<const scene::Mesh*> ptrs;
        for (const auto& m : meshes) ptrs.push_back(&m);
        scene::Device dev("threads=1");
        const auto t0 = Clock::now();
        const scene::Scene sc(dev.device, ptrs);
        const double build_ms = ms_since(t0);
        View v(cam);
        v.render(sc.scene, nt);
        const Rays r = mirror_rays(v, sc.scene, meshes_diameter(meshes), nt);
        const double e1 = embree_ns(sc.scene, r, 1);
        const double e8 = embree8_ns(sc.scene, r, packets(r, v.w));
        Frame f;
        f.normals = v.normal;
        f.mask.assign(v.normal.size(), 0);
        for (uint32_t p : r.pixel) {
            f.mask[p] = 1;
            f.normals[p] = refl_vec3{0.0f, 1.0f, 0.0f};
        }
        f.depth.push_back(encode(v, REFL_DEPTH_CONVENTION_REVERSED_Z));
        const refl_gbuffer gb = f.gbuffer(0);
        PassOut out;
        const Prepared ps = prepare(gb, ks[0].opt);
        const double s1 = median_seconds(kTimingRuns, [&] { out = trace_pass(gb, ks[0].opt, ps.scratch, 1); });
        CHECK(out.ok);
        const Stats st_s = evaluate(r, out);
        CHECK(ks[3].opt.method == REFL_SSR_METHOD_HIZ && ks[3].name.rfind("default", 0) == 0);
        const Prepared ph = prepare(gb, ks[3].opt);
        const double h1 = median_seconds(kTimingRuns, [&] { out = trace_pass(gb, ks[3].opt, ph.scratch, 1); });
        CHECK(out.ok);
        const Stats st_h = evaluate(r, out);
        CHECK(ps.ok && ph.ok);
        // The bare Hi-Z kernel, refl_hiz_trace_rays (the AVX2 ray stream
        // where the CPU has it), against Embree on the same rays: the
        // reflection rays lifted 1e-3 diameters off the mirror floor (the
        // kernel has no self-intersection skip), constant thickness,
        // default options, one batch call on one thread.
        Rays rl = r;
        const float lift = float(1e-3 * meshes_diameter(meshes));
        for (refl_ray& q : rl.ray) q.origin.y += lift;
        const double e1k = embree_ns(sc.scene, rl, 1);
        const double e8k = embree8_ns(sc.scene, rl, packets(rl, v.w));
        size_t plen = 0;
        uint32_t plevels = 0;
        REQUIRE(refl_hiz_len(&plen, &plevels, v.w, v.h) == REFL_STATUS_OK);
        std::vector<refl_vec2> pyr(plen, refl_vec2{0.0f, 0.0f});
        CHECK_STATUS(refl_hiz_build(pyr.data(), pyr.size(), &gb.depth), REFL_STATUS_OK);
        const refl_hiz hz{pyr.data(), pyr.size(), gb.depth.camera, gb.depth.convention};
        refl_trace_thickness kth{};
        kth.constant = float(kThicknessOfDiameter * meshes_diameter(meshes));
        kth.back_faces = refl_image_f32{nullptr, 0, 0, 0, 0};
        const refl_hiz_options hopt = refl_hiz_options_default();
        std::vector<refl_trace_result> kout(rl.size());
        const float kmax = kInf;
        const double k1 = median_seconds(kTimingRuns, [&] {
            CHECK_STATUS(refl_hiz_trace_rays(kout.data(), kout.size(), &hz, &kth, rl.ray.data(), rl.size(), &kmax, 1,
                                             &hopt),
                         REFL_STATUS_OK);
        });
        // The kernel hits where Embree does (within a pixel of the
        // projection of Embree's hit) on the visible reflections.
        size_t kvis = 0, kfound = 0;
        uint64_t kiter = 0, kfetch = 0;
        for (size_t i = 0; i < rl.size(); ++i) {
            kiter += kout[i].iterations;
            kfetch += kout[i].fetches;
            if (!r.visible[i]) continue;
            ++kvis;
            kfound += kout[i].miss == REFL_TRACE_MISS_NONE &&
                      std::hypot(double(kout[i].pixel.x) - r.ref_px[i], double(kout[i].pixel.y) - r.ref_py[i]) <= 1.5;
        }
        CHECK(kvis > 1000 && kfound * 10 >= kvis * 9);
        CHECK(st_s.nan == 0 && st_h.nan == 0);
        const double n = double(std::max<size_t>(r.size(), 1));
        std::printf("  %9zu %7zu | %12.1f %10.1f %10.1f | %10.1f %10.1f %10.2f %12.1f | %8.4f %8.4f\n",
                    triangles(meshes), r.size(), build_ms, e1, e8, s1 * 1e9 / n, h1 * 1e9 / n, ph.ms,
                    (h1 + ph.ms * 1e-3) * 1e9 / n, st_s.hit_rate(), st_h.hit_rate());
        uint32_t lanes = 0;
        CHECK_STATUS(refl_hiz_stream_lanes(&lanes), REFL_STATUS_OK);
        kernel_lines.push_back([&] {
            char line[200];
            std::snprintf(line, sizeof line, "  %9zu %7zu | %10.1f %10.1f | %10.1f %10.2f %10.2f | %5u | %8.4f",
                          triangles(meshes), rl.size(), e1k, e8k, k1 * 1e9 / n, double(kiter) / n, double(kfetch) / n, lanes,
                          kvis ? double(kfound) / double(kvis) : 0.0);
            return std::string(line);
        }());
        // Machine-readable: refl's rays per second over Embree's (above 1:
        // refl is faster), the pass's trace on one thread (default Hi-Z,
        // stride-1 stepping) against Embree on the same rays, at the main
        // size (100k triangles) and at 1M.
        const char* suffix = target == main_target ? "_1t" : target == 1000000 ? "_1t_1m" : nullptr;
        if (suffix) {
            char line[160];
            const double hz = h1 * 1e9 / n, st = s1 * 1e9 / n;
            const double kz = k1 * 1e9 / n;
            for (const auto& [name, value] : {std::make_pair("hiz_vs_embree1", e1 / hz),
                                              std::make_pair("hiz_vs_embree8", e8 / hz),
                                              std::make_pair("step_vs_embree1", e1 / st),
                                              std::make_pair("hiz_kernel_vs_embree1", e1k / kz),
                                              std::make_pair("hiz_kernel_vs_embree8", e8k / kz)}) {
                std::snprintf(line, sizeof line, "ratio %s%s %.4f", name, suffix, value);
                ratio_lines.push_back(line);
            }
        }
    }
    std::printf("\n  the bare Hi-Z kernel (refl_hiz_trace_rays, one batch, default options) on the same rays lifted "
                "1e-3 diameters off the floor, against Embree on those rays; found: share of the visible "
                "reflections hit within 1.5 px of Embree's\n");
    std::printf("  %9s %7s | %10s %10s | %10s %10s %10s | %5s | %8s\n", "triangles", "rays", "embree x1", "embree x8",
                "hiz rays", "iter/ray", "fetch/ray", "lanes", "found");
    std::printf("  %9s %7s | %10s %10s | %10s %10s %10s | %5s | %8s\n", "", "", "ns/ray", "ns/ray", "ns/ray", "", "", "", "");
    for (const std::string& l : kernel_lines) std::printf("%s\n", l.c_str());
    std::printf("\n");
    for (const std::string& l : ratio_lines) std::printf("%s\n", l.c_str());
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
