// ssr_example.cpp: screen-space mirror reflections with refl over a
// G-buffer the host made (here with Embree: a torus, a box and a sphere
// standing on a mirror floor), in five refl calls with default options:
//   refl_camera_look_at, refl_ssr_options_default, refl_ssr_scratch_len,
//   refl_ssr_prepare, refl_ssr_trace_rows.
// The pixels refl cannot answer come back as a ray list, traced here with
// Embree (a hybrid pipeline without callbacks). The example then checks
// refl's hits against Embree's reflections and prints the share of the
// visible reflections found within one pixel, without and with a
// back-face depth image; it fails below 99%.
#include <cmath>
#include <cstdio>
#include <vector>

#include "refl.h"
#include "scene.hpp"

using scene::V3;

static bool ok(refl_status s, const char* what) {
    if (s != REFL_STATUS_OK) std::fprintf(stderr, "%s: %s\n", what, refl_status_string(s));
    return s == REFL_STATUS_OK;
}

static V3 normalize(V3 v) { return (1.0 / scene::length(v)) * v; }

// The host's G-buffer: reversed-Z depth, world normals, a mirror mask (the
// floor), lit color, and the back-face depth of the same pixels.
struct GBuffer {
    uint32_t w, h;
    std::vector<float> depth, back;
    std::vector<refl_vec3> normal, color;
    std::vector<uint8_t> mirror;
    std::vector<V3> position;  // exact surface points (for the check)
};

int main() {
    scene::set_ftz_daz();
    scene::Device device;
    const std::vector<scene::Mesh> meshes = {
        scene::quad({-8, 0, 6}, {8, 0, 6}, {8, 0, -10}, {-8, 0, -10}),  // 0: the mirror floor (one-sided)
        scene::torus({-1.2, 0.45, -1.5}, 0.9, 0.45, 48, 24),             // 1: standing on it
        scene::box({1.6, 0.7, -2.6}, {0.6, 0.7, 0.6}, 0.5),              // 2
        scene::sphere({0.4, 0.8, -4.2}, 0.8, 24, 48),                    // 3
    };
    std::vector<const scene::Mesh*> ptrs;
    for (const auto& m : meshes) ptrs.push_back(&m);
    const scene::Scene world(device.device, ptrs);

    // 1. The camera.
    refl_camera cam;
    if (!ok(refl_camera_look_at(&cam, {0.3f, 1.6f, 4.5f}, {0.0f, 0.5f, -2.0f}, {0.0f, 1.0f, 0.0f}, 1.0f, 0.05f,
                                100.0f, 320, 240),
            "refl_camera_look_at"))
        return 1;

    // The host's G-buffer pass (Embree primary rays; a rasterizer in an engine).
    GBuffer g{cam.width, cam.height, {}, {}, {}, {}, {}, {}};
    const size_t n = size_t(g.w) * g.h;
    const double zn = cam.z_near, zf = cam.z_far;
    auto reversed_z = [&](double z) { return float(zn * (zf - z) / (z * (zf - zn))); };
    g.depth.assign(n, 0.0f);  // reversed-Z clears to 0 (the far plane)
    g.back.assign(n, 0.0f);
    g.normal.assign(n, {0, 0, 0});
    g.color.assign(n, {0.3f, 0.5f, 0.9f});  // sky
    g.mirror.assign(n, 0);
    g.position.assign(n, {0, 0, 0});
    double v[16], inv[16];
    for (int k = 0; k < 16; ++k) v[k] = cam.view.m[k];
    // The inverse of a rigid view: transpose the rotation.
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) inv[c * 4 + r] = v[r * 4 + c];
    for (int r = 0; r < 3; ++r) inv[12 + r] = -(inv[r] * v[12] + inv[4 + r] * v[13] + inv[8 + r] * v[14]);
    const V3 eye{inv[12], inv[13], inv[14]};
    const double ty = std::tan(double(cam.fov_y) * 0.5), tx = ty * g.w / g.h;
    auto primary = [&](double px, double py) {
        const double x = (2.0 * px / g.w - 1.0) * tx, y = (1.0 - 2.0 * py / g.h) * ty;
        return normalize({inv[0] * x + inv[4] * y - inv[8], inv[1] * x + inv[5] * y - inv[9],
                          inv[2] * x + inv[6] * y - inv[10]});
    };
    auto depth_of = [&](V3 p) { return -(v[2] * p.x + v[6] * p.y + v[10] * p.z + v[14]); };
    const float eo[3] = {float(eye.x), float(eye.y), float(eye.z)};
    for (uint32_t y = 0; y < g.h; ++y)
        for (uint32_t x = 0; x < g.w; ++x) {
            const size_t i = size_t(y) * g.w + x;
            const V3 d = primary(x + 0.5, y + 0.5);
            const float df[3] = {float(d.x), float(d.y), float(d.z)};
            RTCIntersectContext ctx;
            rtcInitIntersectContext(&ctx);
            RTCRayHit rh{};
            rh.ray = {eo[0], eo[1], eo[2], 0.0f, df[0], df[1], df[2], 0.0f, 1e30f, 0xFFFFFFFFu, 0, 0};
            rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
            rtcIntersect1(world.scene, &ctx, &rh);
            if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) continue;
            V3 ng = normalize({rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z});
            if (scene::dot(ng, d) > 0) ng = -1.0 * ng;
            const V3 p = eye + double(rh.ray.tfar) * d;
            g.position[i] = p;
            g.depth[i] = reversed_z(depth_of(p));
            g.normal[i] = {float(ng.x), float(ng.y), float(ng.z)};
            g.mirror[i] = rh.hit.geomID == 0;
            const float shade = float(0.35 + 0.65 * std::fabs(ng.y * 0.6 + ng.x * 0.3 + ng.z * 0.74));
            const float tint[4][3] = {{0.5f, 0.5f, 0.5f}, {0.9f, 0.3f, 0.2f}, {0.2f, 0.8f, 0.3f}, {0.9f, 0.8f, 0.2f}};
            g.color[i] = {tint[rh.hit.geomID][0] * shade, tint[rh.hit.geomID][1] * shade,
                          tint[rh.hit.geomID][2] * shade};
            // The back-face pass: the nearest back face behind the surface
            // (a one-sided floor has none: the cleared far plane).
            float t = rh.ray.tfar;
            for (int k = 0; k < 16; ++k) {
                RTCRayHit b{};
                b.ray = {eo[0], eo[1], eo[2], std::nextafter(t, 1e30f), df[0], df[1], df[2], 0.0f, 1e30f, 0xFFFFFFFFu, 0, 0};
                b.hit.geomID = RTC_INVALID_GEOMETRY_ID;
                rtcIntersect1(world.scene, &ctx, &b);
                if (b.hit.geomID == RTC_INVALID_GEOMETRY_ID) break;
                t = b.ray.tfar;
                if (b.hit.Ng_x * df[0] + b.hit.Ng_y * df[1] + b.hit.Ng_z * df[2] > 0) {
                    g.back[i] = reversed_z(depth_of(eye + double(t) * d));
                    break;
                }
            }
        }

    // 2-4. The pass: default options, scratch size, prepare.
    const refl_ssr_options options = refl_ssr_options_default();
    refl_gbuffer gb{};
    gb.depth = {{g.depth.data(), n, g.w, g.h, g.w}, cam, REFL_DEPTH_CONVENTION_REVERSED_Z};
    gb.normals = {g.normal.data(), n, g.w, g.h, g.w};
    gb.normal_space = REFL_NORMAL_SPACE_WORLD;
    gb.mask = {g.mirror.data(), n, g.w, g.h, g.w};
    gb.color = {g.color.data(), n, g.w, g.h, g.w};
    size_t scratch_len = 0;
    if (!ok(refl_ssr_scratch_len(&scratch_len, &gb, &options), "refl_ssr_scratch_len")) return 1;
    std::vector<refl_vec2> scratch(scratch_len);

    bool pass_all = true;
    for (int with_back = 0; with_back < 2; ++with_back) {
        gb.back_depth = with_back ? refl_image_f32{g.back.data(), n, g.w, g.h, g.w} : refl_image_f32{nullptr, 0, 0, 0, 0};
        if (!ok(refl_ssr_prepare(scratch.data(), scratch_len, &gb, &options), "refl_ssr_prepare")) return 1;
        // 5. Trace every row (an engine splits the rows across its threads).
        std::vector<refl_ssr_texel> texels(n);
        std::vector<refl_vec3> reflection(n);
        std::vector<refl_host_ray> host(n);
        refl_ssr_stats stats;
        if (!ok(refl_ssr_trace_rows(&stats, texels.data(), n, {reflection.data(), n, g.w, g.h, g.w}, host.data(), n,
                                    &gb, &options, scratch.data(), scratch_len, {0, g.h}),
                "refl_ssr_trace_rows"))
            return 1;
        // The host traces the rays refl could not answer.
        size_t host_hits = 0;
        for (uint32_t k = 0; k < stats.host_rays_written; ++k) {
            const refl_host_ray& r = host[k];
            const float o[3] = {r.origin.x, r.origin.y, r.origin.z}, d[3] = {r.dir.x, r.dir.y, r.dir.z};
            host_hits += scene::trace(world.scene, o, d, 1e-3f).hit();
        }

        // The check: refl's hits against Embree's reflections.
        size_t visible = 0, found = 0, false_hits = 0;
        for (uint32_t y = 0; y < g.h; ++y)
            for (uint32_t x = 0; x < g.w; ++x) {
                const size_t i = size_t(y) * g.w + x;
                if (!g.mirror[i]) continue;
                const V3 p = g.position[i], d = primary(x + 0.5, y + 0.5);
                const V3 r = d - 2.0 * scene::dot(d, {0, 1, 0}) * V3{0, 1, 0};
                const float o[3] = {float(p.x), float(p.y), float(p.z)}, rd[3] = {float(r.x), float(r.y), float(r.z)};
                const scene::Hit e = scene::trace(world.scene, o, rd, 1e-4f);
                bool vis = false;
                double qx = 0, qy = 0;
                if (e.hit()) {
                    const V3 q = p + double(e.t) * r;
                    const double z = depth_of(q);
                    const double vx = v[0] * q.x + v[4] * q.y + v[8] * q.z + v[12];
                    const double vy = v[1] * q.x + v[5] * q.y + v[9] * q.z + v[13];
                    qx = (vx / z / tx + 1.0) * 0.5 * g.w;
                    qy = (1.0 - vy / z / ty) * 0.5 * g.h;
                    if (z > zn && qx >= 0 && qy >= 0 && qx < g.w && qy < g.h) {
                        const V3 to = q - eye;
                        const double dist = scene::length(to);
                        const V3 u = (1.0 / dist) * to;
                        const float uf[3] = {float(u.x), float(u.y), float(u.z)};
                        const scene::Hit s = scene::trace(world.scene, eo, uf, 0.0f);
                        vis = s.hit() && s.t >= dist * (1.0 - 1e-4);
                    }
                }
                visible += vis;
                const refl_ssr_texel& t = texels[i];
                if (t.status == REFL_SSR_STATUS_HIT) {
                    const bool near = vis && std::hypot(t.pixel.x - qx, t.pixel.y - qy) <= 1.0;
                    found += near;
                    false_hits += !near;
                }
            }
        const double rate = 100.0 * double(found) / double(visible ? visible : 1);
        std::printf("%s: %u mirror rays, %u hits, %u sky, %u to the host (Embree hit %zu of them); "
                    "%zu visible reflections, %.2f%% found within 1 px, %zu false hits\n",
                    with_back ? "with a back-face image" : "constant thickness", stats.traced, stats.hits,
                    stats.sky, stats.host_rays, host_hits, visible, rate, false_hits);
        pass_all = pass_all && visible > 1000 && rate >= 99.0;
    }
    return pass_all ? 0 : 1;
}
