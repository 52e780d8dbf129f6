// planar_reflection: refl's mirrored camera against Embree-traced reflection
// rays.
//
// A C++-built scene (a large planar mirror, three walls, boxes and spheres,
// one box standing on the mirror and one sphere hovering just above it) is
// traced with Embree 3. For every pixel whose primary ray hits the mirror:
//
//   reference: the primary ray's exact intersection P with the mirror plane
//              (double precision) and its reflection r = d - 2 (d.n) n
//              (double), traced from P with Embree;
//   refl:      the primary ray of refl_mirror_camera through the same
//              pixel (refl_camera_primary_ray), traced from the mirror plane
//              on (tnear = refl_plane_intersect_ray: geometry behind the
//              mirror is excluded).
//
// Reflected rays are traced in a scene without the mirror (same geometry
// ids): a planar mirror cannot be hit twice. Asserts, per view, that the hit
// primitive agrees on >= 99.9% of the mirror pixels and bounds the hit-point
// distance (relative to the scene diameter) where it agrees.
#include <algorithm>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <vector>

#include "check.hpp"
#include "refl.h"
#include "scene.hpp"

using scene::V3;

namespace {

constexpr unsigned kMirror = 0;
constexpr uint32_t kWidth = 512, kHeight = 384;

refl_vec3 rv(V3 v) {
    return {static_cast<float>(v.x), static_cast<float>(v.y), static_cast<float>(v.z)};
}
V3 dv(refl_vec3 v) { return {v.x, v.y, v.z}; }

struct ViewStats {
    long mirror_pixels = 0, agree = 0, both_hit = 0, agree_hit = 0;
    double max_err = 0.0, sum_err = 0.0;        // agreeing hits, relative to the diameter
    double max_err_any = 0.0;                   // every pixel where both hit
    double max_plane_gap = 0.0;                 // |refl ray at tnear - P| / diameter
};

ViewStats run_view(const char* name, RTCScene all, RTCScene objects, double diameter, V3 eye, V3 target,
                   const refl_plane& plane) {
    ViewStats st;
    refl_camera cam;
    REQUIRE(refl_camera_look_at(&cam, rv(eye), rv(target), refl_vec3{0.0f, 1.0f, 0.0f}, 0.9f, 0.05f, 100.0f,
                                kWidth, kHeight) == REFL_STATUS_OK);
    refl_camera mirrored;
    REQUIRE(refl_mirror_camera(&mirrored, &cam, &plane) == REFL_STATUS_OK);
    bool is_mirrored = false;
    CHECK_STATUS(refl_camera_is_mirrored(&is_mirrored, &mirrored), REFL_STATUS_OK);
    CHECK(is_mirrored);

    // The mirrored eye is the mirror image of the eye.
    refl_vec3 e0, e1, me;
    CHECK_STATUS(refl_camera_eye(&e0, &cam), REFL_STATUS_OK);
    CHECK_STATUS(refl_camera_eye(&e1, &mirrored), REFL_STATUS_OK);
    CHECK_STATUS(refl_mirror_point(&me, &plane, e0), REFL_STATUS_OK);
    CHECK(scene::length(dv(e1) - dv(me)) < 1e-5 * diameter);

    const V3 n{plane.normal.x, plane.normal.y, plane.normal.z};
    const double pd = plane.d;
    for (uint32_t y = 0; y < kHeight; ++y) {
        for (uint32_t x = 0; x < kWidth; ++x) {
            const refl_vec2 px{static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f};
            refl_ray r0;
            if (refl_camera_primary_ray(&r0, &cam, px) != REFL_STATUS_OK) {
                CHECK(false);
                continue;
            }
            const float o0[3] = {r0.origin.x, r0.origin.y, r0.origin.z};
            const float d0[3] = {r0.dir.x, r0.dir.y, r0.dir.z};
            const scene::Hit h0 = scene::trace(all, o0, d0, 0.0f);
            if (h0.geom != kMirror) continue;
            ++st.mirror_pixels;

            // Reference, in double: exact plane hit and reflection.
            const V3 o = dv(r0.origin), d = dv(r0.dir);
            const double tp = -(scene::dot(n, o) + pd) / scene::dot(n, d);
            const V3 p = o + tp * d;
            const V3 r = d - (2.0 * scene::dot(d, n)) * n;
            const float po[3] = {static_cast<float>(p.x), static_cast<float>(p.y), static_cast<float>(p.z)};
            const float rd[3] = {static_cast<float>(r.x), static_cast<float>(r.y), static_cast<float>(r.z)};
            const scene::Hit href = scene::trace(objects, po, rd, 0.0f);

            // refl: the mirrored camera's primary ray from the plane on.
            refl_ray m;
            float tnear = 0.0f;
            if (refl_camera_primary_ray(&m, &mirrored, px) != REFL_STATUS_OK ||
                refl_plane_intersect_ray(&tnear, &plane, m) != REFL_STATUS_OK) {
                CHECK(false);
                continue;
            }
            const V3 mo = dv(m.origin), md = dv(m.dir);
            st.max_plane_gap = std::max(st.max_plane_gap, scene::length(mo + double(tnear) * md - p) / diameter);
            const float mo3[3] = {m.origin.x, m.origin.y, m.origin.z};
            const float md3[3] = {m.dir.x, m.dir.y, m.dir.z};
            const scene::Hit hrefl = scene::trace(objects, mo3, md3, std::max(tnear, 0.0f));

            const bool same = href.geom == hrefl.geom && href.prim == hrefl.prim;
            st.agree += same;
            if (href.hit() && hrefl.hit()) {
                ++st.both_hit;
                const V3 qa = p + double(href.t) * r;
                const V3 qb = mo + double(hrefl.t) * md;
                const double err = scene::length(qa - qb) / diameter;
                st.max_err_any = std::max(st.max_err_any, err);
                if (same) {
                    ++st.agree_hit;
                    st.max_err = std::max(st.max_err, err);
                    st.sum_err += err;
                }
            }
        }
    }
    const double share = st.mirror_pixels ? double(st.agree) / double(st.mirror_pixels) : 0.0;
    std::printf(
        "[%s] %ux%u: mirror pixels %ld (%.1f%% of the image), reflected rays hitting geometry %ld\n"
        "[%s] same primitive: %ld / %ld = %.4f%%\n"
        "[%s] hit-point distance / scene diameter (same primitive): max %.3e, mean %.3e;"
        " over all pixels where both hit: max %.3e\n"
        "[%s] refl ray at tnear vs exact mirror hit: max %.3e of the diameter\n",
        name, kWidth, kHeight, st.mirror_pixels, 100.0 * double(st.mirror_pixels) / (kWidth * kHeight),
        st.both_hit, name, st.agree, st.mirror_pixels, 100.0 * share, name, st.max_err,
        st.agree_hit ? st.sum_err / double(st.agree_hit) : 0.0, st.max_err_any, name, st.max_plane_gap);
    CHECK(st.mirror_pixels > long(kWidth * kHeight / 10));
    CHECK(st.both_hit > st.mirror_pixels / 2);
    CHECK(share >= 0.999);
    CHECK(st.max_err <= 1e-4);
    CHECK(st.agree_hit == 0 || st.sum_err / double(st.agree_hit) <= 1e-5);
    CHECK(st.max_plane_gap <= 1e-5);
    return st;
}

}  // namespace

int main() {
    scene::set_ftz_daz();
    scene::Device dev;

    const double H = 8.0;
    std::vector<scene::Mesh> meshes;
    // 0: the mirror, y = 0.
    meshes.push_back(scene::quad({-H, 0, H}, {H, 0, H}, {H, 0, -H}, {-H, 0, -H}));
    // 1-3: back, left and right walls standing on the mirror's edges.
    meshes.push_back(scene::quad({-H, 0, -H}, {H, 0, -H}, {H, H, -H}, {-H, H, -H}));
    meshes.push_back(scene::quad({-H, 0, H}, {-H, 0, -H}, {-H, H, -H}, {-H, H, H}));
    meshes.push_back(scene::quad({H, 0, -H}, {H, 0, H}, {H, H, H}, {H, H, -H}));
    // 4: a box standing on the mirror (its bottom face lies in the plane).
    meshes.push_back(scene::box({-1.5, 0.6, -1.0}, {0.6, 0.6, 0.6}, 0.5));
    // 5: a sphere above the mirror.
    meshes.push_back(scene::sphere({1.5, 1.2, -0.5}, 0.8, 24, 48));
    // 6: a floating, rotated box.
    meshes.push_back(scene::box({0.5, 2.2, -3.0}, {0.5, 0.3, 0.8}, -0.3));
    // 7: a small sphere hovering 0.05 above the mirror.
    meshes.push_back(scene::sphere({2.5, 0.35, 1.5}, 0.3, 16, 32));

    std::vector<const scene::Mesh*> all, objects;
    size_t tris = 0;
    for (const auto& m : meshes) {
        all.push_back(&m);
        objects.push_back(&m);
        tris += m.triangle_count();
    }
    objects[kMirror] = nullptr;
    const scene::Scene scene_all(dev.device, all);
    const scene::Scene scene_objects(dev.device, objects);
    // Scene bounds: [-H, H] x [0, H] x [-H, H].
    const double diameter = std::sqrt(4 * H * H + H * H + 4 * H * H);
    std::printf("scene: %zu triangles in %zu meshes, diameter %.3f\n", tris, meshes.size(), diameter);

    // The mirror plane, from one of its triangles.
    refl_plane plane;
    REQUIRE(refl_plane_from_triangle(&plane, refl_vec3{-8.0f, 0.0f, 8.0f}, refl_vec3{8.0f, 0.0f, 8.0f},
                                     refl_vec3{8.0f, 0.0f, -8.0f}) == REFL_STATUS_OK);
    CHECK(std::fabs(std::fabs(plane.normal.y) - 1.0f) < 1e-7f);
    CHECK(std::fabs(plane.d) < 1e-7f);

    run_view("overview", scene_all.scene, scene_objects.scene, diameter, {0.3, 2.5, 7.0}, {0.0, 0.6, -1.0},
             plane);
    run_view("grazing", scene_all.scene, scene_objects.scene, diameter, {-0.7, 0.35, 6.5}, {0.2, 0.5, -2.0},
             plane);
    return check::finish("planar_reflection");
}
