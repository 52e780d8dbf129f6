// epipolar_embree: seed 002 (reprojected ray casting of a walkthrough) with
// Embree as the host's tracer. A walkthrough-like scene (floor, walls with a
// doorway, pillars, crates, spheres) is rendered along a forward walk three
// ways in the same run, single-threaded:
//
//   orsa      rtcIntersect1 on the whole scene for every pixel;
//   epipolar  refl_epipolar_reproject + refl_epipolar_decide_rows, then
//             rtcIntersect1 on the predicted object's own Embree scene
//             ("test object O only"), full traversal where refl says so or
//             where that test misses;
//   irsa      the object ORSA hit, tested alone (the ideal predictor).
//
// Every pixel of every frame is compared with ORSA: a visibility error is a
// different hit (another object, or a distance differing by more than 1e-4
// relative), and there must be none. c_R, c_E, c_O and the time ratios are
// printed (measured, not asserted).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <vector>

#include "check.hpp"
#include "refl.h"
#include "scene.hpp"

namespace {

using scene::Mesh;
using scene::V3;

constexpr uint32_t kW = 320, kH = 240;
constexpr int kFrames = 24;
constexpr float kBackground = 1000.0f;  // background sphere radius (Sec. 5.2)

// A quad subdivided into n x n cells (more triangles for the BVH to skip).
Mesh grid(V3 a, V3 u, V3 v, int n) {
    Mesh m;
    for (int j = 0; j <= n; ++j)
        for (int i = 0; i <= n; ++i) m.add_vertex(a + (double(i) / n) * u + (double(j) / n) * v);
    const uint32_t row = uint32_t(n + 1);
    for (uint32_t j = 0; j < uint32_t(n); ++j)
        for (uint32_t i = 0; i < uint32_t(n); ++i) {
            const uint32_t k = j * row + i;
            m.add_triangle(k, k + 1, k + row + 1);
            m.add_triangle(k, k + row + 1, k + row);
        }
    return m;
}

std::vector<Mesh> build_scene() {
    std::vector<Mesh> v;
    // Floor and ceiling-less room 12 x 24 (x in [-6, 6], z in [-22, 2]).
    v.push_back(grid({-6, 0, 2}, {12, 0, 0}, {0, 0, -24}, 48));
    v.push_back(grid({-6, 0, 2}, {0, 0, -24}, {0, 3, 0}, 24));   // left wall
    v.push_back(grid({6, 0, -22}, {0, 0, 24}, {0, 3, 0}, 24));   // right wall
    v.push_back(grid({-6, 0, -22}, {12, 0, 0}, {0, 3, 0}, 24));  // back wall
    // A cross wall with a doorway at z = -10.
    v.push_back(scene::box({-3.6, 1.5, -10}, {2.4, 1.5, 0.1}, 0.0));
    v.push_back(scene::box({3.6, 1.5, -10}, {2.4, 1.5, 0.1}, 0.0));
    v.push_back(scene::box({0, 2.6, -10}, {1.2, 0.4, 0.1}, 0.0));
    // Pillars, crates and spheres on both sides of the walk.
    for (int k = 0; k < 6; ++k) {
        const double z = -3.0 - 3.2 * k;
        v.push_back(scene::box({-2.5, 1.5, z}, {0.25, 1.5, 0.25}, 0.0));
        v.push_back(scene::box({2.8, 0.35, z + 1.1}, {0.35, 0.35, 0.35}, 0.4 * k));
        v.push_back(scene::sphere({1.6, 0.5, z - 0.8}, 0.5, 24, 48));
        v.push_back(scene::sphere({-1.2, 0.3, z + 1.5}, 0.3, 16, 32));
    }
    return v;
}

// The camera of frame k: walking along -z with a slow sway and yaw.
refl_camera camera(int k) {
    const double s = 0.05 * k;
    const double x = 0.3 * std::sin(0.35 * s);
    const float eye[3] = {float(x), 1.6f, float(1.0 - s)};
    const float yaw = float(0.08 * std::sin(0.5 * s));
    refl_camera c{};
    const refl_status st =
        refl_camera_look_at(&c, refl_vec3{eye[0], eye[1], eye[2]},
                            refl_vec3{eye[0] + 10.0f * std::sin(yaw), 1.3f, eye[2] - 10.0f * std::cos(yaw)},
                            refl_vec3{0, 1, 0}, 1.1f, 0.05f, 200.0f, kW, kH);
    REQUIRE(st == REFL_STATUS_OK);
    return c;
}

std::vector<refl_ray> rays_of(const refl_camera& c) {
    std::vector<refl_ray> r(size_t(kW) * kH);
    for (uint32_t y = 0; y < kH; ++y)
        for (uint32_t x = 0; x < kW; ++x)
            REQUIRE(refl_camera_primary_ray(&r[size_t(y) * kW + x], &c,
                                            refl_vec2{float(x) + 0.5f, float(y) + 0.5f}) == REFL_STATUS_OK);
    return r;
}

scene::Hit trace(RTCScene s, const refl_ray& r, float tnear, float tfar) {
    const float o[3] = {r.origin.x, r.origin.y, r.origin.z};
    const float d[3] = {r.dir.x, r.dir.y, r.dir.z};
    return scene::trace(s, o, d, tnear, tfar);
}

enum class Agree { Same, Tie, Error };

Agree agree(const scene::Hit& a, const scene::Hit& b) {
    if (!a.hit() || !b.hit()) return a.hit() == b.hit() ? Agree::Same : Agree::Error;
    if (std::fabs(a.t - b.t) > 1e-4f * std::max(a.t, b.t)) return Agree::Error;
    return a.geom == b.geom ? Agree::Same : Agree::Tie;
}

double now_ms() {
    using namespace std::chrono;
    return duration<double, std::milli>(steady_clock::now().time_since_epoch()).count();
}

}  // namespace

int main() {
    scene::set_ftz_daz();
    scene::Device dev("threads=1");
    const std::vector<Mesh> meshes = build_scene();
    size_t tris = 0;
    std::vector<const Mesh*> all;
    for (const Mesh& m : meshes) {
        all.push_back(&m);
        tris += m.triangle_count();
    }
    scene::Scene full(dev.device, all);
    // One Embree scene per object, geometry id kept (the "test object O
    // only" of Alg. 2).
    std::vector<std::unique_ptr<scene::Scene>> objects;
    for (size_t k = 0; k < meshes.size(); ++k) {
        std::vector<const Mesh*> one(meshes.size(), nullptr);
        one[k] = &meshes[k];
        objects.push_back(std::make_unique<scene::Scene>(dev.device, one));
    }

    refl_epipolar_options params = refl_epipolar_options_default();
    const size_t n = size_t(kW) * kH;
    size_t scratch_len = 0;
    REQUIRE(refl_epipolar_scratch_len(&scratch_len, kW, kH) == REFL_STATUS_OK);
    std::vector<refl_epipolar_pos_entry> pos(n);
    std::vector<refl_epipolar_aip_entry> aip(n, refl_epipolar_aip_entry{REFL_EPIPOLAR_INVALID_OBJECT, INFINITY, 0u,
                                                                        INFINITY, REFL_EPIPOLAR_FLAG_NO_REPROJECTION});
    std::vector<float> scratch(scratch_len);
    std::vector<refl_epipolar_decision> decisions(n);
    std::vector<scene::Hit> truth(n), ours(n), ideal(n);

    double t_orsa = 0, t_irsa = 0, t_method = 0, t_reproject = 0;
    long resolved = 0, failed = 0, resampled = 0, steady = 0, errors = 0, ties = 0, irsa_errors = 0;
    long frustum_failed = 0;
    refl_camera previous{};
    for (int f = 0; f < kFrames; ++f) {
        const refl_camera cam = camera(f);
        const std::vector<refl_ray> rays = rays_of(cam);
        // ORSA.
        double t0 = now_ms();
        for (size_t i = 0; i < n; ++i) truth[i] = trace(full.scene, rays[i], 0.0f, INFINITY);
        const double orsa_ms = now_ms() - t0;
        // IRSA.
        t0 = now_ms();
        for (size_t i = 0; i < n; ++i)
            ideal[i] = truth[i].hit() ? trace(objects[truth[i].geom]->scene, rays[i], 0.0f, INFINITY) : scene::Hit{};
        const double irsa_ms = now_ms() - t0;
        for (size_t i = 0; i < n; ++i) irsa_errors += agree(ideal[i], truth[i]) == Agree::Error;
        // The method: reprojection, decisions, tracing, POS of this frame.
        t0 = now_ms();
        if (f > 0) {
            refl_epipolar_stats stats{};
            CHECK_STATUS(refl_epipolar_reproject(aip.data(), n, scratch.data(), scratch.size(), &stats, pos.data(),
                                                 n, &previous, &cam, &params),
                         REFL_STATUS_OK);
            frustum_failed += stats.frustum_failed;
        }
        const double t_rep = now_ms() - t0;
        CHECK_STATUS(refl_epipolar_decide_rows(decisions.data(), n, aip.data(), n, kW, refl_row_range{0, kH}, uint32_t(f), &params),
                     REFL_STATUS_OK);
        long f_resolved = 0, f_failed = 0, f_resampled = 0;
        for (size_t i = 0; i < n; ++i) {
            const refl_epipolar_decision& d = decisions[i];
            scene::Hit h;
            bool done = false;
            if (d.reason == REFL_EPIPOLAR_REASON_REPROJECTED) {
                if (d.object == REFL_EPIPOLAR_BACKGROUND_OBJECT) {
                    done = true;  // background: no ray/object test at all
                } else if (d.object < objects.size()) {
                    h = trace(objects[d.object]->scene, rays[i], 0.0f, d.tmax);
                    done = h.hit() && h.t < d.tmax;
                }
                if (done) ++f_resolved;
            }
            if (!done) {
                h = trace(full.scene, rays[i], d.tmin, INFINITY);
                if (d.reason == REFL_EPIPOLAR_REASON_RESAMPLED)
                    ++f_resampled;
                else
                    ++f_failed;
            }
            ours[i] = h;
            const refl_ray& r = rays[i];
            refl_epipolar_pos_entry& p = pos[i];
            const float t = h.hit() ? h.t : kBackground;
            p.point[0] = r.origin.x + t * r.dir.x;
            p.point[1] = r.origin.y + t * r.dir.y;
            p.point[2] = r.origin.z + t * r.dir.z;
            p.object = h.hit() ? h.geom : REFL_EPIPOLAR_BACKGROUND_OBJECT;
            p.t = t;
        }
        const double method_ms = now_ms() - t0;
        previous = cam;
        for (size_t i = 0; i < n; ++i) {
            const Agree a = agree(ours[i], truth[i]);
            if (a == Agree::Tie) ++ties;
            if (a == Agree::Error) {
                if (errors < 20)
                    std::fprintf(stderr, "visibility error: frame %d pixel (%zu, %zu): ORSA geom %u t %.6f, method geom %u t %.6f (reason %u)\n",
                                 f, i % kW, i / kW, truth[i].geom, double(truth[i].t), ours[i].geom,
                                 double(ours[i].t), decisions[i].reason);
                ++errors;
            }
        }
        if (f > 0) {  // frame 0 has no reprojection: the steady state is 1..
            t_orsa += orsa_ms;
            t_irsa += irsa_ms;
            t_method += method_ms;
            t_reproject += t_rep;
            resolved += f_resolved;
            failed += f_failed;
            resampled += f_resampled;
            steady += long(n);
        }
    }
    const double c_r = double(resolved) / double(steady), c_e = double(failed) / double(steady),
                 c_o = double(resampled) / double(steady);
    std::printf("epipolar_embree: %zu triangles, %zu objects, %d frames at %ux%u, 1 thread\n", tris, meshes.size(),
                kFrames, kW, kH);
    std::printf("  frames 1..: c_R %.1f%%, c_E %.1f%%, c_O %.1f%%; view-frustum failures %ld\n", 100 * c_r, 100 * c_e,
                100 * c_o, frustum_failed);
    std::printf("  ms/frame: orsa %.2f, epipolar %.2f (reprojection %.2f), irsa %.2f\n", t_orsa / (kFrames - 1),
                t_method / (kFrames - 1), t_reproject / (kFrames - 1), t_irsa / (kFrames - 1));
    std::printf("  speed: epipolar %.2fx ORSA, %.2fx IRSA time; IRSA %.2fx ORSA\n", t_orsa / t_method,
                t_method / t_irsa, t_orsa / t_irsa);
    std::printf("  visibility errors %ld, ties (same point, another object) %ld; IRSA errors %ld\n", errors, ties,
                irsa_errors);
    CHECK_EQ(errors, 0L);
    CHECK_EQ(irsa_errors, 0L);
    CHECK_EQ(frustum_failed, 0L);
    // The decisions do their job: most pixels take one test, and the
    // regular-resampling share is 1/N.
    CHECK(c_r > 0.3);
    CHECK(std::fabs(c_o - 1.0 / 9.0) < 0.01);
    return check::finish("epipolar_embree");
}
