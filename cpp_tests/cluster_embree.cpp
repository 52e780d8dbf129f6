// cluster_embree: seed 003's second-order feed-forward reflections through
// the C ABI against Embree, on a dynamic scene (the BVH is rebuilt every
// frame, rtcCommitScene included in Embree's frame time, at
// RTC_BUILD_QUALITY_LOW, the dynamic-scene setting).
//
// Scene: a planar mirror floor (object 0), a mirror sphere (object 1),
// boxes and a field of diffuse spheres whose tessellation sets the
// triangle count (10k and 100k by default; 1M with the argument `1m`).
// Per scene size, single thread on both sides:
//
//  * first pass (not timed, shared): G-buffer from Embree primary rays;
//  * Embree: scene build + commit (the per-frame rebuild) and one
//    rtcIntersect1 per reflective pixel;
//  * refl: the cluster pass. refl_cluster_plan_len and refl_cluster_plan
//    (clustering and cameras, one call, from the G-buffer: linear depth,
//    normals, object ids, one lobe per reflective object), a z-buffer
//    rasterizer written here with object-level culling against the plan's
//    frustum and clip planes (depth images, one cluster at a time, buffers
//    reused: what a host's GPU would do), refl_cluster_finalize_rows per
//    cluster over its rows (intersection). The host calls: 3 per frame and
//    1 per cluster (before the pass: 6 per frame and 2 per cluster, with
//    the finalize input, surface positions and culling math written here).
//
// Correctness (asserted): every texel's color is its object's id color,
// so a pixel's finalized color names the object its reflected ray found;
// it must agree with Embree's hit object (or the environment on both
// sides) on most reflective pixels. Time is reported, not asserted.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "check.hpp"
#include "refl.h"
#include "scene.hpp"

namespace {

using scene::Mesh;
using scene::V3;
using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t0) {
    return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

#ifdef REFL_SANITIZE
constexpr uint32_t W = 96, H = 72;
#else
constexpr uint32_t W = 256, H = 192;
#endif

// Color of object k: distinct, exactly representable components.
refl_vec3 object_color(uint32_t k) {
    return {float((k * 37u) % 11u) / 16.0f, float((k * 53u) % 13u) / 16.0f, float(k % 7u) / 16.0f + 0.5f};
}

struct World {
    std::vector<Mesh> meshes;    // object k = meshes[k]
    std::vector<V3> lo, hi;      // bounds per object
    size_t triangles = 0;
};

World build_world(size_t target_tris) {
    World w;
    w.meshes.push_back(scene::quad({-8, 0, 8}, {8, 0, 8}, {8, 0, -8}, {-8, 0, -8}));  // mirror floor
    w.meshes.push_back(scene::sphere({0.0, 1.0, -1.0}, 1.0, 48, 96));                 // mirror sphere
    w.meshes.push_back(scene::box({-2.5, 0.75, 0.5}, {0.5, 0.75, 0.5}, 0.4));
    w.meshes.push_back(scene::box({2.5, 1.0, -2.0}, {0.6, 1.0, 0.6}, -0.3));
    w.meshes.push_back(scene::quad({-8, 0, -8}, {8, 0, -8}, {8, 5, -8}, {-8, 5, -8}));  // back wall
    size_t have = 0;
    for (const Mesh& m : w.meshes) have += m.triangle_count();
    // Diffuse spheres on a ring, tessellated to reach the target.
    const int count = 24;
    const size_t per = target_tris > have ? (target_tris - have) / count : 8;
    const int seg = std::max(4, int(std::sqrt(double(per))));
    for (int i = 0; i < count; ++i) {
        const double a = 6.2831853 * i / count;
        w.meshes.push_back(scene::sphere({5.0 * std::cos(a), 0.45, -1.0 + 5.0 * std::sin(a)}, 0.45, seg / 2 + 1, seg));
    }
    for (const Mesh& m : w.meshes) {
        V3 l{1e30, 1e30, 1e30}, h{-1e30, -1e30, -1e30};
        for (size_t i = 0; i < m.vertices.size(); i += 3) {
            l = {std::min(l.x, double(m.vertices[i])), std::min(l.y, double(m.vertices[i + 1])),
                 std::min(l.z, double(m.vertices[i + 2]))};
            h = {std::max(h.x, double(m.vertices[i])), std::max(h.y, double(m.vertices[i + 1])),
                 std::max(h.z, double(m.vertices[i + 2]))};
        }
        w.lo.push_back(l);
        w.hi.push_back(h);
        w.triangles += m.triangle_count();
    }
    return w;
}

// View-space transform of a refl_camera (column-major view matrix).
struct Proj {
    float m[16];
    float tx, ty, w, h, near_z;
    explicit Proj(const refl_camera& c) {
        std::memcpy(m, c.view.m, sizeof(m));
        ty = std::tan(0.5f * c.fov_y);
        tx = ty * float(c.width) / float(c.height);
        w = float(c.width);
        h = float(c.height);
        near_z = c.z_near;
    }
    V3 view(const float p[3]) const {
        return {m[0] * p[0] + m[4] * p[1] + m[8] * p[2] + m[12], m[1] * p[0] + m[5] * p[1] + m[9] * p[2] + m[13],
                m[2] * p[0] + m[6] * p[1] + m[10] * p[2] + m[14]};
    }
};

// The z-buffer of one cluster camera: linear depth (+inf: empty) and the
// object id per texel; the clip plane keeps n.p + d > 0; objects entirely
// outside one of the frustum planes (the plan's) are culled.
void rasterize(const World& w, const refl_camera& cam, const refl_plane& clip, const refl_vec4 (&frustum)[6],
               int skip_object, std::vector<float>& depth, std::vector<uint32_t>& object) {
    const Proj pr(cam);
    const uint32_t cw = cam.width, ch = cam.height;
    depth.assign(size_t(cw) * ch, std::numeric_limits<float>::infinity());
    object.assign(size_t(cw) * ch, 0xFFFFFFFFu);
    const double nx = clip.normal.x, ny = clip.normal.y, nz = clip.normal.z, nd = clip.d;
    for (size_t k = 0; k < w.meshes.size(); ++k) {
        if (int(k) == skip_object) continue;
        // Object culling: all corners behind the clip plane, or outside one
        // frustum plane.
        int behind = 0, out[6] = {0, 0, 0, 0, 0, 0};
        for (int c = 0; c < 8; ++c) {
            const float p[3] = {float((c & 1) ? w.hi[k].x : w.lo[k].x), float((c & 2) ? w.hi[k].y : w.lo[k].y),
                                float((c & 4) ? w.hi[k].z : w.lo[k].z)};
            behind += (nx * p[0] + ny * p[1] + nz * p[2] + nd) <= 0.0;
            for (int f = 0; f < 6; ++f)
                out[f] += frustum[f].x * p[0] + frustum[f].y * p[1] + frustum[f].z * p[2] + frustum[f].w < 0.0f;
        }
        if (behind == 8 || std::any_of(out, out + 6, [](int o) { return o == 8; })) continue;
        const Mesh& m = w.meshes[k];
        for (size_t t = 0; t < m.triangle_count(); ++t) {
            // Clip (world: clip plane; view: near plane), Sutherland-Hodgman.
            V3 poly[5], tmp[5];
            int n = 0, nt;
            for (int i = 0; i < 3; ++i) {
                const float* p = &m.vertices[3 * m.indices[3 * t + i]];
                poly[n++] = {p[0], p[1], p[2]};
            }
            auto clip_by = [&](auto dist) {
                nt = 0;
                for (int i = 0; i < n; ++i) {
                    const V3 a = poly[i], b = poly[(i + 1) % n];
                    const double da = dist(a), db = dist(b);
                    if (da > 0 && nt < 5) tmp[nt++] = a;
                    if ((da > 0) != (db > 0) && nt < 5) tmp[nt++] = a + (da / (da - db)) * (b - a);
                }
                n = nt;
                for (int i = 0; i < n; ++i) poly[i] = tmp[i];
            };
            clip_by([&](V3 p) { return nx * p.x + ny * p.y + nz * p.z + nd; });
            if (n < 3) continue;
            for (int i = 0; i < n; ++i) {
                const float p[3] = {float(poly[i].x), float(poly[i].y), float(poly[i].z)};
                poly[i] = pr.view(p);
            }
            clip_by([&](V3 v) { return -v.z - pr.near_z; });
            if (n < 3) continue;
            double sx[5], sy[5], iz[5];
            for (int i = 0; i < n; ++i) {
                const double z = -poly[i].z;
                sx[i] = (poly[i].x / (z * pr.tx) + 1.0) * 0.5 * pr.w;
                sy[i] = (1.0 - poly[i].y / (z * pr.ty)) * 0.5 * pr.h;
                iz[i] = 1.0 / z;
            }
            for (int f = 1; f + 1 < n; ++f) {
                const int a = 0, b = f, c = f + 1;
                const double area = (sx[b] - sx[a]) * (sy[c] - sy[a]) - (sy[b] - sy[a]) * (sx[c] - sx[a]);
                if (area == 0.0) continue;
                const double x0 = std::max(0.0, std::floor(std::min({sx[a], sx[b], sx[c]}) - 0.5));
                const double x1 = std::min(double(cw) - 1, std::ceil(std::max({sx[a], sx[b], sx[c]})));
                const double y0 = std::max(0.0, std::floor(std::min({sy[a], sy[b], sy[c]}) - 0.5));
                const double y1 = std::min(double(ch) - 1, std::ceil(std::max({sy[a], sy[b], sy[c]})));
                for (double y = y0; y <= y1; ++y) {
                    for (double x = x0; x <= x1; ++x) {
                        const double px = x + 0.5, py = y + 0.5;
                        const double w0 = ((sx[b] - px) * (sy[c] - py) - (sy[b] - py) * (sx[c] - px)) / area;
                        const double w1 = ((sx[c] - px) * (sy[a] - py) - (sy[c] - py) * (sx[a] - px)) / area;
                        const double w2 = 1.0 - w0 - w1;
                        if (w0 < 0 || w1 < 0 || w2 < 0) continue;
                        const double z = 1.0 / (w0 * iz[a] + w1 * iz[b] + w2 * iz[c]);
                        const size_t i = size_t(y) * cw + size_t(x);
                        if (z < depth[i]) {
                            depth[i] = float(z);
                            object[i] = uint32_t(k);
                        }
                    }
                }
            }
        }
    }
}

// An Embree scene of `meshes` (mesh k = geometry k) built at `quality`:
// the per-frame rebuild of a dynamic scene (RTC_BUILD_QUALITY_LOW is what
// Embree suggests for those; MEDIUM is its default).
RTCScene build_scene(RTCDevice device, const std::vector<Mesh>& meshes, RTCBuildQuality quality) {
    RTCScene sc = rtcNewScene(device);
    rtcSetSceneBuildQuality(sc, quality);
    rtcSetSceneFlags(sc, RTC_SCENE_FLAG_DYNAMIC);
    for (size_t k = 0; k < meshes.size(); ++k) {
        const Mesh& m = meshes[k];
        RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
        rtcSetGeometryBuildQuality(g, quality);
        float* v = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                               3 * sizeof(float), m.vertices.size() / 3));
        std::memcpy(v, m.vertices.data(), m.vertices.size() * sizeof(float));
        unsigned* ix = static_cast<unsigned*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                                      3 * sizeof(unsigned), m.triangle_count()));
        std::memcpy(ix, m.indices.data(), m.indices.size() * sizeof(unsigned));
        rtcCommitGeometry(g);
        rtcAttachGeometryByID(sc, g, static_cast<unsigned>(k));
        rtcReleaseGeometry(g);
    }
    rtcCommitScene(sc);
    return sc;
}

struct Row {
    size_t triangles = 0, reflective = 0, clusters = 0, cameras = 0, agree = 0, fallbacks = 0, host_rays = 0;
    double rebuild_medium_ms = 0, rebuild_ms = 0, embree_trace_ms = 0, plan_ms = 0, raster_ms = 0, finalize_ms = 0;
};

Row run(RTCDevice device, size_t target) {
    Row row;
    const World w = build_world(target);
    row.triangles = w.triangles;
    // Embree: the per-frame rebuild (LOW, the dynamic-scene quality, is the
    // one charged to Embree's frame; MEDIUM for reference), then the first
    // pass (not timed).
    auto t0 = Clock::now();
    RTCScene medium = build_scene(device, w.meshes, RTC_BUILD_QUALITY_MEDIUM);
    row.rebuild_medium_ms = ms_since(t0);
    rtcReleaseScene(medium);
    t0 = Clock::now();
    struct Owned {
        RTCScene scene;
        ~Owned() { rtcReleaseScene(scene); }
    } s{build_scene(device, w.meshes, RTC_BUILD_QUALITY_LOW)};
    row.rebuild_ms = ms_since(t0);
    const V3 eye{0.3, 2.2, 6.0}, target_pt{0.0, 0.6, -1.0};
    refl_camera cam;
    CHECK_STATUS(refl_camera_look_at(&cam, refl_vec3{float(eye.x), float(eye.y), float(eye.z)},
                                     refl_vec3{float(target_pt.x), float(target_pt.y), float(target_pt.z)},
                                     refl_vec3{0, 1, 0}, 1.0f, 0.05f, 100.0f, W, H),
                 REFL_STATUS_OK);
    const size_t N = size_t(W) * H;
    std::vector<refl_vec3> pos(N, refl_vec3{0, 0, 0}), nrm(N, refl_vec3{0, 1, 0});
    std::vector<float> depth_g(N, std::numeric_limits<float>::infinity());
    std::vector<uint32_t> obj(N, 0xFFFFFFFFu);
    for (uint32_t y = 0; y < H; ++y) {
        for (uint32_t x = 0; x < W; ++x) {
            refl_ray r;
            refl_camera_primary_ray(&r, &cam, refl_vec2{x + 0.5f, y + 0.5f});
            const float o[3] = {r.origin.x, r.origin.y, r.origin.z}, d[3] = {r.dir.x, r.dir.y, r.dir.z};
            const scene::Hit h = scene::trace(s.scene, o, d, 0.0f);
            if (!h.hit() || h.geom > 1) continue;
            const size_t i = size_t(y) * W + x;
            const V3 p{o[0] + h.t * d[0], o[1] + h.t * d[1], o[2] + h.t * d[2]};
            V3 n{0, 1, 0};
            if (h.geom == 1) n = (1.0 / scene::length(p - V3{0.0, 1.0, -1.0})) * (p - V3{0.0, 1.0, -1.0});
            pos[i] = {float(p.x), float(p.y), float(p.z)};
            nrm[i] = {float(n.x), float(n.y), float(n.z)};
            REQUIRE(refl_camera_linear_depth(&depth_g[i], &cam, pos[i]) == REFL_STATUS_OK);
            obj[i] = h.geom;
            ++row.reflective;
        }
    }
    // Embree: one reflection ray per reflective pixel.
    std::vector<uint32_t> embree_obj(N, 0xFFFFFFFFu);
    t0 = Clock::now();
    for (size_t i = 0; i < N; ++i) {
        if (obj[i] == 0xFFFFFFFFu) continue;
        const uint32_t x = uint32_t(i % W), y = uint32_t(i / W);
        refl_ray r;
        refl_camera_primary_ray(&r, &cam, refl_vec2{x + 0.5f, y + 0.5f});
        const float k = 2.0f * (-r.dir.x * nrm[i].x - r.dir.y * nrm[i].y - r.dir.z * nrm[i].z);
        const float d[3] = {r.dir.x + k * nrm[i].x, r.dir.y + k * nrm[i].y, r.dir.z + k * nrm[i].z};
        const float o[3] = {pos[i].x, pos[i].y, pos[i].z};
        const scene::Hit h = scene::trace(s.scene, o, d, 1e-4f);
        embree_obj[i] = h.hit() ? h.geom : 0xFFFFFFFFu;
    }
    row.embree_trace_ms = ms_since(t0);

    // refl: the plan (clustering, cameras, frusta, resolutions).
    refl_gbuffer gb{};
    gb.depth = {{depth_g.data(), N, W, H, W}, cam, REFL_DEPTH_CONVENTION_LINEAR};
    gb.normals = {nrm.data(), N, W, H, W};
    gb.normal_space = REFL_NORMAL_SPACE_WORLD;
    gb.mask = {nullptr, 0, 0, 0, 0};
    gb.roughness = {nullptr, 0, 0, 0, 0};
    gb.color = {nullptr, 0, 0, 0, 0};
    gb.back_depth = {nullptr, 0, 0, 0, 0};
    // Objects 0 and 1 are mirrors; every other id is not reflective.
    const refl_cluster_lobe lobes[2] = {{1, 0.0f, 0.0f}, {1, 0.0f, 0.0f}};
    const refl_cluster_objects objects{{obj.data(), N, W, H, W}, lobes, 2};
    refl_cluster_pass_options po = refl_cluster_pass_options_default();
    po.cluster.gain = 64.0f;
    po.camera.far_distance = 30.0f;
    po.thickness = 0.05f / po.camera.far_distance;
    t0 = Clock::now();
    refl_cluster_plan_sizes sizes{};
    CHECK_STATUS(refl_cluster_plan_len(&sizes, &gb, &objects, &po), REFL_STATUS_OK);
    std::vector<uint32_t> scratch(sizes.scratch_len);
    std::vector<refl_cluster_plan_entry> clusters(sizes.clusters_len);
    refl_cluster_plan_stats plan{};
    CHECK_STATUS(refl_cluster_plan(&plan, clusters.data(), clusters.size(), scratch.data(), scratch.size(), &gb,
                                   &objects, &po),
                 REFL_STATUS_OK);
    row.plan_ms = ms_since(t0);
    CHECK_EQ(size_t(plan.pixels), row.reflective);
    row.clusters = plan.clusters;
    row.cameras = plan.cameras;

    std::vector<float> depth;
    std::vector<uint32_t> texel_obj;
    std::vector<refl_vec3> color;
    std::vector<refl_cluster_texel> texels(N);
    std::vector<refl_host_ray> host(N);
    const uint32_t* order = scratch.data() + N;
    for (uint32_t c = 0; c < plan.clusters; ++c) {
        const refl_cluster_plan_entry& e = clusters[c];
        const uint32_t* px = order + e.first;
        refl_cluster_stats st{};
        if (e.camera.fallback != REFL_CLUSTER_FALLBACK_NONE) {
            // No camera: the pass hands every pixel to the host.
            CHECK_STATUS(refl_cluster_finalize_rows(&st, texels.data(), N, host.data(), N, &gb, &po, scratch.data(),
                                                    scratch.size(), &e, nullptr, e.rows),
                         REFL_STATUS_OK);
        } else {
            t0 = Clock::now();
            rasterize(w, e.camera.camera, e.camera.clip, e.frustum, e.camera.planar ? int(e.object) : -1, depth,
                      texel_obj);
            color.resize(depth.size());
            for (size_t i = 0; i < depth.size(); ++i)
                color[i] = texel_obj[i] == 0xFFFFFFFFu ? refl_vec3{0, 0, 0} : object_color(texel_obj[i]);
            row.raster_ms += ms_since(t0);
            const uint32_t dw = e.camera.camera.width, dh = e.camera.camera.height;
            const refl_cluster_render render{{{depth.data(), depth.size(), dw, dh, dw}, e.camera.camera,
                                              REFL_DEPTH_CONVENTION_LINEAR},
                                             {color.data(), color.size(), dw, dh, dw},
                                             {nullptr, 0, 0, 0, 0},
                                             {nullptr, 0, 0, 0, 0},
                                             {nullptr, 0, 0, 0, 0}};
            t0 = Clock::now();
            CHECK_STATUS(refl_cluster_finalize_rows(&st, texels.data(), N, host.data(), N, &gb, &po, scratch.data(),
                                                    scratch.size(), &e, &render, e.rows),
                         REFL_STATUS_OK);
            row.finalize_ms += ms_since(t0);
        }
        CHECK_EQ(st.pixels, e.len);
        row.host_rays += st.host_rays;
        for (size_t k = 0; k < e.len; ++k) {
            const refl_cluster_shade& sh = texels[px[k]].shade;
            const uint32_t want = embree_obj[px[k]];
            row.fallbacks += sh.env_weight > 0.0f;
            if (sh.hits == 0) {
                row.agree += want == 0xFFFFFFFFu;
                continue;
            }
            if (want == 0xFFFFFFFFu) continue;
            const refl_vec3 wc = object_color(want);
            row.agree += std::fabs(sh.rgb.x - wc.x) < 1e-3f && std::fabs(sh.rgb.y - wc.y) < 1e-3f &&
                         std::fabs(sh.rgb.z - wc.z) < 1e-3f;
        }
    }
    return row;
}

}  // namespace

int main(int argc, char** argv) {
    scene::set_ftz_daz();
    scene::Device dev("threads=1");
    std::vector<size_t> sizes = {10000, 100000};
    if (argc > 1 && std::string(argv[1]) == "1m") sizes.push_back(1000000);
#ifdef REFL_SANITIZE
    sizes = {10000};
#endif
    std::printf("cluster_embree: %ux%u, single thread; Embree frame = rebuild + trace; cluster frame = plan "
                "(clustering + cameras) + depth images (C++ z-buffer) + intersection\n",
                W, H);
    std::printf("| triangles | reflective px | clusters (cameras) | Embree rebuild LOW ms (MEDIUM) | Embree trace ms | "
                "plan ms | depth images ms | intersection ms | (rebuild LOW+trace)/cluster | agree | fallback | "
                "host rays |\n");
    for (size_t target : sizes) {
        const Row r = run(dev.device, target);
        const double cluster = r.plan_ms + r.raster_ms + r.finalize_ms;
        const double agree = double(r.agree) / double(std::max<size_t>(1, r.reflective));
        std::printf("| %zu | %zu | %zu (%zu) | %.2f (%.2f) | %.2f | %.2f | %.2f | %.2f | %.2f | %.4f | %.4f | %zu |\n",
                    r.triangles, r.reflective, r.clusters, r.cameras, r.rebuild_ms, r.rebuild_medium_ms,
                    r.embree_trace_ms, r.plan_ms, r.raster_ms, r.finalize_ms,
                    (r.rebuild_ms + r.embree_trace_ms) / cluster, agree,
                    double(r.fallbacks) / double(std::max<size_t>(1, r.reflective)), r.host_rays);
        CHECK(r.reflective > size_t(W) * H / 10);
        CHECK(r.cameras >= 2);
        // Most reflected rays find the object Embree finds.
        CHECK(agree > 0.9);
    }
    return check::finish("cluster_embree");
}
