// scene.hpp: triangle meshes built in C++ and traced with Embree 3, shared
// by the C++ tests.
#ifndef REFL_CPP_TESTS_SCENE_HPP
#define REFL_CPP_TESTS_SCENE_HPP

#include <embree3/rtcore.h>
#include <pmmintrin.h>
#include <xmmintrin.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <vector>

namespace scene {

struct V3 {
    double x, y, z;
};
inline V3 operator+(V3 a, V3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline V3 operator-(V3 a, V3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline V3 operator*(double s, V3 a) { return {s * a.x, s * a.y, s * a.z}; }
inline double dot(V3 a, V3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline double length(V3 a) { return std::sqrt(dot(a, a)); }

// An indexed triangle mesh in single precision (what Embree traces).
struct Mesh {
    std::vector<float> vertices;     // x, y, z per vertex
    std::vector<uint32_t> indices;   // three per triangle

    uint32_t add_vertex(V3 p) {
        vertices.push_back(static_cast<float>(p.x));
        vertices.push_back(static_cast<float>(p.y));
        vertices.push_back(static_cast<float>(p.z));
        return static_cast<uint32_t>(vertices.size() / 3 - 1);
    }
    void add_triangle(uint32_t a, uint32_t b, uint32_t c) {
        indices.push_back(a);
        indices.push_back(b);
        indices.push_back(c);
    }
    size_t triangle_count() const { return indices.size() / 3; }
};

// A quad a b c d (counter-clockwise seen from its front) as two triangles.
inline Mesh quad(V3 a, V3 b, V3 c, V3 d) {
    Mesh m;
    uint32_t ia = m.add_vertex(a), ib = m.add_vertex(b), ic = m.add_vertex(c), id = m.add_vertex(d);
    m.add_triangle(ia, ib, ic);
    m.add_triangle(ia, ic, id);
    return m;
}

// A box with half extents h, rotated by `yaw` radians about +Y, centered at c.
inline Mesh box(V3 c, V3 h, double yaw) {
    Mesh m;
    const double cs = std::cos(yaw), sn = std::sin(yaw);
    for (int i = 0; i < 8; ++i) {
        V3 p{(i & 1) ? h.x : -h.x, (i & 2) ? h.y : -h.y, (i & 4) ? h.z : -h.z};
        m.add_vertex({c.x + cs * p.x + sn * p.z, c.y + p.y, c.z - sn * p.x + cs * p.z});
    }
    const uint32_t faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                                  {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    for (const auto& f : faces) {
        m.add_triangle(f[0], f[1], f[2]);
        m.add_triangle(f[0], f[2], f[3]);
    }
    return m;
}

// A UV sphere with `rings` latitude bands and `segments` longitude bands.
inline Mesh sphere(V3 c, double r, int rings, int segments) {
    Mesh m;
    const double pi = 3.14159265358979323846;
    for (int i = 0; i <= rings; ++i) {
        const double th = pi * i / rings;
        for (int j = 0; j <= segments; ++j) {
            const double ph = 2.0 * pi * j / segments;
            m.add_vertex({c.x + r * std::sin(th) * std::cos(ph), c.y + r * std::cos(th),
                          c.z + r * std::sin(th) * std::sin(ph)});
        }
    }
    const uint32_t row = static_cast<uint32_t>(segments + 1);
    for (uint32_t i = 0; i < static_cast<uint32_t>(rings); ++i) {
        for (uint32_t j = 0; j < static_cast<uint32_t>(segments); ++j) {
            const uint32_t a = i * row + j, b = a + row;
            if (i != 0) m.add_triangle(a, b, a + 1);
            if (i + 1 != static_cast<uint32_t>(rings)) m.add_triangle(a + 1, b, b + 1);
        }
    }
    return m;
}

// A torus around the +Y axis through c: major radius R, minor radius r,
// `rings` segments around the axis and `sides` around the tube, every quad
// wound the same way (a closed, consistently oriented mesh).
inline Mesh torus(V3 c, double R, double r, int rings, int sides) {
    Mesh m;
    const double pi = 3.14159265358979323846;
    for (int i = 0; i < rings; ++i) {
        const double u = 2.0 * pi * i / rings;
        for (int j = 0; j < sides; ++j) {
            const double v = 2.0 * pi * j / sides, w = R + r * std::cos(v);
            m.add_vertex({c.x + w * std::cos(u), c.y + r * std::sin(v), c.z + w * std::sin(u)});
        }
    }
    const uint32_t nr = static_cast<uint32_t>(rings), ns = static_cast<uint32_t>(sides);
    for (uint32_t i = 0; i < nr; ++i) {
        for (uint32_t j = 0; j < ns; ++j) {
            const uint32_t a = i * ns + j, b = ((i + 1) % nr) * ns + j;
            const uint32_t cc = ((i + 1) % nr) * ns + (j + 1) % ns, d = i * ns + (j + 1) % ns;
            m.add_triangle(a, b, cc);
            m.add_triangle(a, cc, d);
        }
    }
    return m;
}

// Sets flush-to-zero and denormals-are-zero, as Embree recommends.
inline void set_ftz_daz() {
    _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
    _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
}

inline void embree_error(void*, RTCError code, const char* msg) {
    std::fprintf(stderr, "embree error %d: %s\n", static_cast<int>(code), msg ? msg : "");
    std::exit(EXIT_FAILURE);
}

// An Embree device; one per test process.
struct Device {
    RTCDevice device;
    explicit Device(const char* config = "threads=1") : device(rtcNewDevice(config)) {
        if (!device) {
            std::fprintf(stderr, "rtcNewDevice failed: %d\n", static_cast<int>(rtcGetDeviceError(nullptr)));
            std::exit(EXIT_FAILURE);
        }
        rtcSetDeviceErrorFunction(device, embree_error, nullptr);
    }
    ~Device() { rtcReleaseDevice(device); }
    Device(const Device&) = delete;
    Device& operator=(const Device&) = delete;
};

// A committed Embree scene of triangle meshes; mesh k gets geometry id k
// (slots given as nullptr stay empty, so ids agree across scenes built from
// subsets of the same mesh list).
struct Scene {
    RTCScene scene;
    Scene(RTCDevice device, const std::vector<const Mesh*>& meshes) : scene(rtcNewScene(device)) {
        rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_HIGH);
        for (size_t k = 0; k < meshes.size(); ++k) {
            if (!meshes[k]) continue;
            const Mesh& m = *meshes[k];
            RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
            float* v = static_cast<float*>(rtcSetNewGeometryBuffer(
                g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), m.vertices.size() / 3));
            for (size_t i = 0; i < m.vertices.size(); ++i) v[i] = m.vertices[i];
            unsigned* ix = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
                g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), m.triangle_count()));
            for (size_t i = 0; i < m.indices.size(); ++i) ix[i] = m.indices[i];
            rtcCommitGeometry(g);
            rtcAttachGeometryByID(scene, g, static_cast<unsigned>(k));
            rtcReleaseGeometry(g);
        }
        rtcCommitScene(scene);
    }
    ~Scene() { rtcReleaseScene(scene); }
    Scene(const Scene&) = delete;
    Scene& operator=(const Scene&) = delete;
};

struct Hit {
    unsigned geom = RTC_INVALID_GEOMETRY_ID;  // RTC_INVALID_GEOMETRY_ID: miss
    unsigned prim = RTC_INVALID_GEOMETRY_ID;
    float t = std::numeric_limits<float>::infinity();
    float ng[3] = {0, 0, 0};  // Embree's geometric normal, not unit (`trace` only)
    bool hit() const { return geom != RTC_INVALID_GEOMETRY_ID; }
};

// rtcIntersect1 of origin + t dir for t in [tnear, tfar].
inline Hit trace(RTCScene s, const float o[3], const float d[3], float tnear,
                 float tfar = std::numeric_limits<float>::infinity()) {
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
    rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(s, &ctx, &rh);
    Hit h;
    if (rh.hit.geomID != RTC_INVALID_GEOMETRY_ID) {
        h.geom = rh.hit.geomID;
        h.prim = rh.hit.primID;
        h.t = rh.ray.tfar;
        h.ng[0] = rh.hit.Ng_x;
        h.ng[1] = rh.hit.Ng_y;
        h.ng[2] = rh.hit.Ng_z;
    }
    return h;
}

// rtcIntersect8 of up to 8 rays (`n` of them; the other lanes are
// inactive): origins o[3 k..], directions d[3 k..], each traced over
// [tnear, inf) into hits[k]. Embree's packet path: the rays of one packet
// should be coherent (neighboring pixels) to gain from it.
inline void trace8(RTCScene s, const float* o, const float* d, size_t n, float tnear, Hit hits[8]) {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    alignas(32) int valid[8];
    alignas(32) RTCRayHit8 rh;
    for (size_t k = 0; k < 8; ++k) {
        const size_t j = k < n ? k : 0;
        valid[k] = k < n ? -1 : 0;
        rh.ray.org_x[k] = o[3 * j];
        rh.ray.org_y[k] = o[3 * j + 1];
        rh.ray.org_z[k] = o[3 * j + 2];
        rh.ray.dir_x[k] = d[3 * j];
        rh.ray.dir_y[k] = d[3 * j + 1];
        rh.ray.dir_z[k] = d[3 * j + 2];
        rh.ray.tnear[k] = tnear;
        rh.ray.tfar[k] = std::numeric_limits<float>::infinity();
        rh.ray.time[k] = 0.0f;
        rh.ray.mask[k] = 0xFFFFFFFFu;
        rh.ray.id[k] = unsigned(k);
        rh.ray.flags[k] = 0;
        rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
        rh.hit.primID[k] = RTC_INVALID_GEOMETRY_ID;
        rh.hit.instID[0][k] = RTC_INVALID_GEOMETRY_ID;
    }
    rtcIntersect8(valid, s, &ctx, &rh);
    for (size_t k = 0; k < 8; ++k) {
        hits[k] = Hit{};
        if (k < n && rh.hit.geomID[k] != RTC_INVALID_GEOMETRY_ID) {
            hits[k].geom = rh.hit.geomID[k];
            hits[k].prim = rh.hit.primID[k];
            hits[k].t = rh.ray.tfar[k];
        }
    }
}

}  // namespace scene

#endif  // REFL_CPP_TESTS_SCENE_HPP
