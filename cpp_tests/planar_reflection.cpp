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
//
// Then the whole planar pass, as a host runs it (refl_planar_options_default,
// refl_planar_prepare, refl_planar_resolve_rows): an Embree G-buffer
// (depth, normals, object ids), the setup, the mirrored render made with
// Embree through the setup's camera, clipped at the mirror and with depth
// written by the setup's (oblique) projection, at full, half and quarter
// resolution; the resolve's answer per mirror pixel (the render texel's
// primitive, or the environment) against Embree tracing the exact mirror
// ray, and its distance to the reflected surface.
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


// A camera's world-space primary rays in double (what a host computes
// itself): the inverse of the view's orthonormal 3x3 part is its transpose.
struct Rays {
    double inv[16];
    double tx, ty;
    uint32_t w, h;
    explicit Rays(const refl_camera& c) : w(c.width), h(c.height) {
        double v[16];
        for (int k = 0; k < 16; ++k) v[k] = c.view.m[k];
        for (int r = 0; r < 3; ++r)
            for (int col = 0; col < 3; ++col) inv[col * 4 + r] = v[r * 4 + col];
        for (int r = 0; r < 3; ++r) inv[12 + r] = -(inv[r] * v[12] + inv[4 + r] * v[13] + inv[8 + r] * v[14]);
        inv[3] = inv[7] = inv[11] = 0.0;
        inv[15] = 1.0;
        ty = std::tan(double(c.fov_y) * 0.5);
        tx = ty * w / h;
    }
    V3 eye() const { return {inv[12], inv[13], inv[14]}; }
    V3 dir(double px, double py) const {
        const double x = (2.0 * px / w - 1.0) * tx, y = (1.0 - 2.0 * py / h) * ty;
        const V3 d{inv[0] * x + inv[4] * y - inv[8], inv[1] * x + inv[5] * y - inv[9],
                   inv[2] * x + inv[6] * y - inv[10]};
        return (1.0 / scene::length(d)) * d;
    }
};

struct PassStats {
    long mirror = 0, covered = 0, agree = 0, hits = 0, env_rays = 0, env_rays_hit = 0;
    double max_t_err = 0.0;
};

// The planar pass over an Embree G-buffer of `cam`, the render made with
// Embree at 1 / scale, the resolve against Embree's exact mirror rays.
PassStats run_pass(const char* name, RTCScene all, RTCScene objects, const std::vector<scene::Mesh>& meshes,
                   const refl_camera& cam, uint32_t convention, const refl_plane& plane, uint32_t scale) {
    PassStats st;
    const uint32_t w = cam.width, h = cam.height;
    const size_t n = size_t(w) * h;
    const double zn = cam.z_near, zf = cam.z_far;
    auto encode = [&](double z) {
        return convention == REFL_DEPTH_CONVENTION_REVERSED_Z ? float(zn * (zf - z) / (z * (zf - zn)))
                                                               : float(zf * (z - zn) / (z * (zf - zn)));
    };
    const float cleared = convention == REFL_DEPTH_CONVENTION_REVERSED_Z ? 0.0f : 1.0f;
    // The host's G-buffer: depth, geometric normals, object ids.
    std::vector<float> depth(n, cleared);
    std::vector<refl_vec3> normals(n, refl_vec3{0, 0, 0});
    std::vector<uint32_t> ids(n, 0xFFFFFFFFu);
    std::vector<V3> points(n, V3{0, 0, 0}), dirs(n, V3{0, 0, 0});
    const Rays rays(cam);
    const V3 eye = rays.eye();
    const V3 fwd{-rays.inv[8], -rays.inv[9], -rays.inv[10]};
    for (uint32_t y = 0; y < h; ++y)
        for (uint32_t x = 0; x < w; ++x) {
            const size_t i = size_t(y) * w + x;
            const V3 d = rays.dir(x + 0.5, y + 0.5);
            const float o3[3] = {float(eye.x), float(eye.y), float(eye.z)};
            const float d3[3] = {float(d.x), float(d.y), float(d.z)};
            const scene::Hit hit = scene::trace(all, o3, d3, 0.0f);
            dirs[i] = d;
            if (!hit.hit()) continue;
            const double z = double(hit.t) * scene::dot(d, fwd);
            if (z >= zf) continue;
            depth[i] = encode(z);
            ids[i] = hit.geom;
            points[i] = eye + double(hit.t) * d;
            const scene::Mesh& m = meshes[hit.geom];
            const uint32_t* t = &m.indices[3 * size_t(hit.prim)];
            const V3 a{m.vertices[3 * t[0]], m.vertices[3 * t[0] + 1], m.vertices[3 * t[0] + 2]};
            const V3 b{m.vertices[3 * t[1]], m.vertices[3 * t[1] + 1], m.vertices[3 * t[1] + 2]};
            const V3 c{m.vertices[3 * t[2]], m.vertices[3 * t[2] + 1], m.vertices[3 * t[2] + 2]};
            const V3 e1 = b - a, e2 = c - a;
            normals[i] = {float(e1.y * e2.z - e1.z * e2.y), float(e1.z * e2.x - e1.x * e2.z),
                          float(e1.x * e2.y - e1.y * e2.x)};
            st.mirror += hit.geom == kMirror;
        }
    refl_gbuffer g{};
    g.depth = {{depth.data(), n, w, h, w}, cam, convention};
    g.normals = {normals.data(), n, w, h, w};
    g.normal_space = REFL_NORMAL_SPACE_WORLD;

    // The pass: setup in one call.
    refl_planar_options options = refl_planar_options_default();
    options.scale = scale;
    const refl_planar_mirror mirror{plane, {ids.data(), n, w, h, w}, kMirror};
    refl_planar_setup setup;
    REQUIRE(refl_planar_prepare(&setup, &g, &mirror, &options) == REFL_STATUS_OK);
    CHECK(setup.covered && setup.flip_winding);
    CHECK_EQ(long(setup.covered_pixels), st.mirror);

    // The host's mirrored render (Embree in place of a rasterizer): the
    // setup camera's rays from the mirror plane on, depth through the
    // setup's projection, the texels of the scissor only.
    const uint32_t rw = setup.camera.width, rh = setup.camera.height;
    const size_t rn = size_t(rw) * rh;
    std::vector<float> rdepth(rn, cleared);
    std::vector<refl_vec3> rcolor(rn, refl_vec3{-1, -1, 0});
    const Rays rr(setup.camera);
    const V3 reye = rr.eye();
    const V3 pn{setup.clip_plane.normal.x, setup.clip_plane.normal.y, setup.clip_plane.normal.z};
    const double* vm = nullptr;
    double view[16], proj[16];
    for (int k = 0; k < 16; ++k) view[k] = setup.camera.view.m[k], proj[k] = setup.projection.m[k];
    vm = view;
    for (uint32_t j = setup.scissor.y0; j < setup.scissor.y1; ++j)
        for (uint32_t i = setup.scissor.x0; i < setup.scissor.x1; ++i) {
            const V3 d = rr.dir(i + 0.5, j + 0.5);
            const double tp = -(scene::dot(pn, reye) + setup.clip_plane.d) / scene::dot(pn, d);
            const float o3[3] = {float(reye.x), float(reye.y), float(reye.z)};
            const float d3[3] = {float(d.x), float(d.y), float(d.z)};
            const scene::Hit hit = scene::trace(objects, o3, d3, float(std::max(tp, 0.0)));
            if (!hit.hit()) continue;
            const V3 p = reye + double(hit.t) * d;
            double v4[4], c4[4];
            for (int r = 0; r < 4; ++r) v4[r] = vm[r] * p.x + vm[4 + r] * p.y + vm[8 + r] * p.z + vm[12 + r];
            for (int r = 0; r < 4; ++r)
                c4[r] = proj[r] * v4[0] + proj[4 + r] * v4[1] + proj[8 + r] * v4[2] + proj[12 + r] * v4[3];
            const float dd = float(c4[2] / c4[3]);
            const size_t k = size_t(j) * rw + i;
            rdepth[k] = dd;
            rcolor[k] = {float(hit.geom), float(hit.prim), 0.0f};
        }

    // The resolve, one call for the image (a host splits it into bands).
    std::vector<refl_planar_texel> texels(n);
    std::vector<refl_vec3> color(n);
    std::vector<refl_host_ray> host(n);
    const refl_planar_render render{{rdepth.data(), rn, rw, rh, rw}, {rcolor.data(), rn, rw, rh, rw}};
    refl_planar_stats rs;
    REQUIRE(refl_planar_resolve_rows(&rs, texels.data(), n, {color.data(), n, w, h, w}, host.data(), n, &g,
                                     &mirror, &options, &render, refl_row_range{0, h}) == REFL_STATUS_OK);
    st.covered = rs.covered;
    const V3 mn{plane.normal.x, plane.normal.y, plane.normal.z};
    for (size_t i = 0; i < n; ++i) {
        const refl_planar_texel& t = texels[i];
        if (t.status != REFL_PLANAR_STATUS_HIT && t.status != REFL_PLANAR_STATUS_ENVIRONMENT) continue;
        // Embree's exact mirror ray from the mirror point.
        const V3 d = dirs[i];
        const double tp = -(scene::dot(mn, eye) + plane.d) / scene::dot(mn, d);
        const V3 p = eye + tp * d;
        const V3 r = d - (2.0 * scene::dot(d, mn)) * mn;
        const float po[3] = {float(p.x), float(p.y), float(p.z)};
        const float rd[3] = {float(r.x), float(r.y), float(r.z)};
        const scene::Hit ref = scene::trace(objects, po, rd, 0.0f);
        // The pass's answer: the anchor texel's primitive (at full
        // resolution also the resolved color, which is that texel's).
        const size_t ak = size_t(t.texel_y) * rw + t.texel_x;
        const refl_vec3 at = rcolor[ak];
        // Every texel read lies within the oblique projection's depth
        // range, up to f32 rounding next to the mirror (objects standing on
        // it: about 3e-8 below the near value here).
        CHECK(rdepth[ak] >= -1e-6f && rdepth[ak] <= 1.0f + 1e-6f);
        if (t.status == REFL_PLANAR_STATUS_HIT) {
            ++st.hits;
            const bool same = ref.hit() && at.x == float(ref.geom) && at.y == float(ref.prim);
            st.agree += same;
            if (scale == 1) CHECK(color[i].x == at.x && color[i].y == at.y);
            // Relative to the reflected path's length from the eye (what
            // the depth's precision scales with; t itself goes to 0 where
            // an object stands on the mirror). Below full resolution t
            // comes from the blended depth around the pixel's reflection.
            if (same) st.max_t_err = std::max(st.max_t_err, std::fabs(double(t.t) - ref.t) / (tp + ref.t));
        } else {
            st.agree += !ref.hit();
        }
    }
    for (uint32_t k = 0; k < rs.host_rays_written; ++k) {
        const refl_host_ray& hr = host[k];
        CHECK(hr.status == REFL_PLANAR_STATUS_ENVIRONMENT);
        const float o3[3] = {hr.origin.x, hr.origin.y, hr.origin.z};
        const float d3[3] = {hr.dir.x, hr.dir.y, hr.dir.z};
        ++st.env_rays;
        st.env_rays_hit += scene::trace(objects, o3, d3, 1e-4f).hit();
    }
    std::printf("[%s pass 1/%u] covered %ld of %ld mirror pixels, render %ux%u (scissor %u..%u x %u..%u); "
                "same answer as Embree's mirror ray: %ld / %ld = %.3f%%; environment rays %ld (%ld hit geometry); "
                "max t error %.2e of the path length\n",
                name, scale, st.covered, st.mirror, rw, rh, setup.scissor.x0, setup.scissor.x1, setup.scissor.y0,
                setup.scissor.y1, st.agree, st.covered, 100.0 * double(st.agree) / double(std::max(st.covered, 1L)),
                st.env_rays, st.env_rays_hit, st.max_t_err);
    CHECK_EQ(st.covered, st.mirror);
    const double share = double(st.agree) / double(std::max(st.covered, 1L));
    // Below full resolution a coarse texel answers for its neighbors too:
    // wrong where a silhouette crosses it (measured: 96% at 1/2, 93% at 1/4).
    CHECK(share >= (scale == 1 ? 0.999 : scale == 2 ? 0.95 : 0.90));
    if (scale == 1) {
        CHECK(st.max_t_err <= 1e-3);
        CHECK(st.env_rays_hit <= st.env_rays / 100);
    }
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

    // The planar pass (three refl calls) against the same Embree rays.
    struct View {
        const char* name;
        refl_vec3 eye, target;
        uint32_t convention;
    };
    const View views[] = {
        {"overview", {0.3f, 2.5f, 7.0f}, {0.0f, 0.6f, -1.0f}, REFL_DEPTH_CONVENTION_ZERO_TO_ONE},
        {"grazing", {-0.7f, 0.35f, 6.5f}, {0.2f, 0.5f, -2.0f}, REFL_DEPTH_CONVENTION_REVERSED_Z},
    };
    for (const View& v : views) {
        refl_camera cam;
        REQUIRE(refl_camera_look_at(&cam, v.eye, v.target, refl_vec3{0.0f, 1.0f, 0.0f}, 0.9f, 0.05f, 100.0f, kWidth,
                                    kHeight) == REFL_STATUS_OK);
        for (uint32_t scale : {1u, 2u, 4u})
            run_pass(v.name, scene_all.scene, scene_objects.scene, meshes, cam, v.convention, plane, scale);
    }
    return check::finish("planar_reflection");
}
