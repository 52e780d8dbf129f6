// obvhs_crosscheck: the root package's obvhs reference tracer against Embree
// on the same rays.
//
// Usage: obvhs_crosscheck <dir>, where <dir> was written by
//     cargo run --release -p refl -- export-crosscheck <dir>
//
// File formats (defined by src/export.rs, repeated here):
//  * scene.obj: `v x y z` and `f a b c` lines (1-based; `a/b/c` forms and
//    negative indices accepted); face k (0-based, in file order) is
//    primitive k. Faces must be triangles.
//  * rays.bin: little-endian; "REFLRAY1", u32 count, u32 reflection_count,
//    then count records of 8 f32: origin xyz, dir xyz, tmin, tmax. The first
//    reflection_count rays are reflection rays, the rest primary rays.
//  * hits.bin: little-endian; "REFLHIT1", u32 count, then count records of
//    u32 prim (0xFFFFFFFF = miss), f32 t, f32 u, f32 v (u, v weight the
//    second and third vertex, Embree's convention).
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
#include "scene.hpp"

namespace {

bool read_file(const std::string& path, std::vector<unsigned char>& out) {
    std::ifstream f(path, std::ios::binary);
    if (!f) return false;
    out.assign(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
    return true;
}

uint32_t le_u32(const unsigned char* p) {
    return uint32_t(p[0]) | (uint32_t(p[1]) << 8) | (uint32_t(p[2]) << 16) | (uint32_t(p[3]) << 24);
}
float le_f32(const unsigned char* p) {
    const uint32_t u = le_u32(p);
    float f;
    std::memcpy(&f, &u, sizeof f);
    return f;
}

[[noreturn]] void die(const std::string& msg) {
    std::fprintf(stderr, "obvhs_crosscheck: %s\n", msg.c_str());
    std::exit(EXIT_FAILURE);
}

// Parses one OBJ face index token ("7", "7/1/2", "-3") into a 0-based index.
long face_index(const std::string& tok, size_t vertex_count) {
    const long i = std::strtol(tok.c_str(), nullptr, 10);
    if (i > 0) return i - 1;
    if (i < 0) return static_cast<long>(vertex_count) + i;
    return -1;
}

scene::Mesh load_obj(const std::string& path) {
    std::ifstream f(path);
    if (!f) die("cannot open " + path);
    scene::Mesh m;
    std::string line;
    size_t line_no = 0;
    while (std::getline(f, line)) {
        ++line_no;
        if (line.size() < 2) continue;
        if (line[0] == 'v' && line[1] == ' ') {
            // strtof: the file holds shortest round-trip decimals of f32
            // values; parsing straight to float recovers them exactly.
            const char* p = line.c_str() + 2;
            char* end = nullptr;
            for (int k = 0; k < 3; ++k) {
                const float x = std::strtof(p, &end);
                if (end == p) die(path + ":" + std::to_string(line_no) + ": bad vertex");
                m.vertices.push_back(x);
                p = end;
            }
        } else if (line[0] == 'f' && line[1] == ' ') {
            std::istringstream s(line.substr(2));
            std::string tok;
            std::vector<long> idx;
            while (s >> tok) idx.push_back(face_index(tok, m.vertices.size() / 3));
            if (idx.size() != 3) die(path + ":" + std::to_string(line_no) + ": face is not a triangle");
            for (long i : idx) {
                if (i < 0 || static_cast<size_t>(i) >= m.vertices.size() / 3)
                    die(path + ":" + std::to_string(line_no) + ": index out of range");
                m.indices.push_back(static_cast<uint32_t>(i));
            }
        }
    }
    return m;
}

struct Ray {
    float o[3], d[3], tmin, tmax;
};
struct RefHit {
    uint32_t prim;
    float t, u, v;
};

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

    const scene::Mesh mesh = load_obj(dir + "/scene.obj");
    if (mesh.triangle_count() == 0) die("scene.obj has no faces");

    std::vector<unsigned char> rb, hb;
    if (!read_file(dir + "/rays.bin", rb)) die("cannot read " + dir + "/rays.bin");
    if (!read_file(dir + "/hits.bin", hb)) die("cannot read " + dir + "/hits.bin");
    if (rb.size() < 16 || std::memcmp(rb.data(), "REFLRAY1", 8) != 0) die("rays.bin: bad header");
    if (hb.size() < 12 || std::memcmp(hb.data(), "REFLHIT1", 8) != 0) die("hits.bin: bad header");
    const uint32_t count = le_u32(rb.data() + 8), reflection_count = le_u32(rb.data() + 12);
    if (rb.size() != 16 + size_t(count) * 32) die("rays.bin: size does not match its count");
    if (le_u32(hb.data() + 8) != count) die("hits.bin: count differs from rays.bin");
    if (hb.size() != 12 + size_t(count) * 16) die("hits.bin: size does not match its count");
    if (reflection_count > count) die("rays.bin: reflection_count > count");

    std::vector<Ray> rays(count);
    std::vector<RefHit> ref(count);
    for (uint32_t i = 0; i < count; ++i) {
        const unsigned char* p = rb.data() + 16 + size_t(i) * 32;
        Ray& r = rays[i];
        for (int k = 0; k < 3; ++k) {
            r.o[k] = le_f32(p + 4 * k);
            r.d[k] = le_f32(p + 12 + 4 * k);
        }
        r.tmin = le_f32(p + 24);
        r.tmax = le_f32(p + 28);
        const unsigned char* q = hb.data() + 12 + size_t(i) * 16;
        ref[i] = {le_u32(q), le_f32(q + 4), le_f32(q + 8), le_f32(q + 12)};
    }

    // Scene bounds, for the report.
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < mesh.vertices.size(); ++i) {
        lo[i % 3] = std::min(lo[i % 3], mesh.vertices[i]);
        hi[i % 3] = std::max(hi[i % 3], mesh.vertices[i]);
    }
    const double diameter = std::sqrt(double(hi[0] - lo[0]) * (hi[0] - lo[0]) +
                                      double(hi[1] - lo[1]) * (hi[1] - lo[1]) +
                                      double(hi[2] - lo[2]) * (hi[2] - lo[2]));
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
