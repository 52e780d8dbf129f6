// obvhs_crosscheck: the root package's obvhs reference tracer against Embree
// on the same rays.
//
// Usage: obvhs_crosscheck <dir>, where <dir> was written by
//     cargo run --release -p refl -- export-crosscheck <dir>
//
// File formats: see crosscheck.hpp.
//
// Each ray is traced with rtcIntersect1 over [tmin, tmax]. Asserts, over all
// rays and per ray kind: the same primitive (a miss counts as a primitive)
// for >= 99.9% of the rays, and for every ray where both hit the same
// primitive |t_embree - t_obvhs| <= 1e-4 * t_obvhs.
#include <embree3/rtcore.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "check.hpp"
#include "crosscheck.hpp"
#include "scene.hpp"

namespace {

using crosscheck::die;

struct Stats {
    const char* name;
    long rays = 0, same = 0, both_hit = 0, t_over = 0;
    double max_rel_t = 0.0, sum_rel_t = 0.0, max_uv = 0.0;
    void print() const {
        std::printf("[%s] rays %ld: same primitive %ld = %.4f%%; same-primitive hits %ld: |dt|/t max %.3e, "
                    "mean %.3e, over 1e-4: %ld; max |d(u,v)| %.3e\n",
                    name, rays, same, rays ? 100.0 * double(same) / double(rays) : 100.0, both_hit, max_rel_t,
                    both_hit ? sum_rel_t / double(both_hit) : 0.0, t_over, max_uv);
    }
    void assert_ok() const {
        CHECK(rays == 0 || double(same) >= 0.999 * double(rays));
        CHECK(t_over == 0);
    }
};

}  // namespace

int main(int argc, char** argv) {
    if (argc != 2) die("usage: obvhs_crosscheck <dir written by `refl export-crosscheck`>");
    const std::string dir = argv[1];
    scene::set_ftz_daz();

    const scene::Mesh mesh = crosscheck::load_obj(dir + "/scene.obj");
    if (mesh.triangle_count() == 0) die("scene.obj has no faces");
    const crosscheck::RaySet set = crosscheck::load_rays(dir);
    const std::vector<crosscheck::Ray>& rays = set.rays;
    const std::vector<crosscheck::RefHit>& ref = set.ref;
    const uint32_t count = static_cast<uint32_t>(rays.size()), reflection_count = set.reflection_count;

    const double diameter = crosscheck::diameter(mesh);
    std::printf("scene: %zu triangles, diameter %.3f; rays: %u (%u reflection, %u primary)\n",
                mesh.triangle_count(), diameter, count, reflection_count, count - reflection_count);

    scene::Device dev("threads=1");
    const scene::Scene sc(dev.device, {&mesh});

    Stats all{"all"}, refl_s{"reflection"}, prim_s{"primary"};
    const auto t0 = std::chrono::steady_clock::now();
    std::vector<scene::Hit> hits(count);
    for (uint32_t i = 0; i < count; ++i) hits[i] = scene::trace(sc.scene, rays[i].o, rays[i].d, rays[i].tmin, rays[i].tmax);
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

    for (uint32_t i = 0; i < count; ++i) {
        const scene::Hit& h = hits[i];
        const uint32_t eprim = h.hit() ? h.prim : 0xFFFFFFFFu;
        for (Stats* s : {&all, i < reflection_count ? &refl_s : &prim_s}) {
            ++s->rays;
            if (eprim != ref[i].prim) continue;
            ++s->same;
            if (eprim == 0xFFFFFFFFu) continue;
            ++s->both_hit;
            const double rel = std::fabs(double(h.t) - double(ref[i].t)) / std::max(double(ref[i].t), 1e-6 * diameter);
            s->max_rel_t = std::max(s->max_rel_t, rel);
            s->sum_rel_t += rel;
            s->t_over += rel > 1e-4;
        }
    }
    // Barycentrics, for information (Embree's u, v at the same primitive).
    {
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        for (uint32_t i = 0; i < count; ++i) {
            if (!hits[i].hit() || hits[i].prim != ref[i].prim) continue;
            RTCRayHit rh{};
            rh.ray.org_x = rays[i].o[0];
            rh.ray.org_y = rays[i].o[1];
            rh.ray.org_z = rays[i].o[2];
            rh.ray.dir_x = rays[i].d[0];
            rh.ray.dir_y = rays[i].d[1];
            rh.ray.dir_z = rays[i].d[2];
            rh.ray.tnear = rays[i].tmin;
            rh.ray.tfar = rays[i].tmax;
            rh.ray.mask = 0xFFFFFFFFu;
            rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
            rtcIntersect1(sc.scene, &ctx, &rh);
            const double du = std::fabs(double(rh.hit.u) - ref[i].u), dv = std::fabs(double(rh.hit.v) - ref[i].v);
            Stats& s = i < reflection_count ? refl_s : prim_s;
            s.max_uv = std::max(s.max_uv, std::max(du, dv));
            all.max_uv = std::max(all.max_uv, std::max(du, dv));
        }
    }
    std::printf("embree rtcIntersect1, 1 thread: %.1f ms, %.2f Mrays/s\n", secs * 1e3,
                secs > 0 ? count / secs * 1e-6 : 0.0);
    all.print();
    refl_s.print();
    prim_s.print();
    CHECK(count > 0);
    all.assert_ok();
    refl_s.assert_ok();
    prim_s.assert_ok();
    return check::finish("obvhs_crosscheck");
}
