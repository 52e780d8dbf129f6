// crosscheck.hpp: readers for the directory `refl export-crosscheck` writes
// (src/export.rs defines the formats; repeated here):
//  * scene.obj: `v x y z` and `f a b c` lines (1-based; `a/b/c` forms and
//    negative indices accepted); face k (0-based, in file order) is
//    primitive k. Faces must be triangles.
//  * rays.bin: little-endian; "REFLRAY1", u32 count, u32 reflection_count,
//    then count records of 8 f32: origin xyz, dir xyz, tmin, tmax. The first
//    reflection_count rays are reflection rays, the rest primary rays.
//  * hits.bin: little-endian; "REFLHIT1", u32 count, then count records of
//    u32 prim (0xFFFFFFFF = miss), f32 t, f32 u, f32 v (u, v weight the
//    second and third vertex, Embree's convention).
//  * meta.txt: `key = value` lines (scene, triangles, width, height, ray
//    counts, epsilon, and the camera: view = 16 f32 column-major, fov_y,
//    near, far).
#ifndef REFL_CPP_TESTS_CROSSCHECK_HPP
#define REFL_CPP_TESTS_CROSSCHECK_HPP

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "scene.hpp"

namespace crosscheck {

[[noreturn]] inline void die(const std::string& msg) {
    std::fprintf(stderr, "crosscheck: %s\n", msg.c_str());
    std::exit(EXIT_FAILURE);
}

inline bool read_file(const std::string& path, std::vector<unsigned char>& out) {
    std::ifstream f(path, std::ios::binary);
    if (!f) return false;
    out.assign(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
    return true;
}

inline uint32_t le_u32(const unsigned char* p) {
    return uint32_t(p[0]) | (uint32_t(p[1]) << 8) | (uint32_t(p[2]) << 16) | (uint32_t(p[3]) << 24);
}
inline float le_f32(const unsigned char* p) {
    const uint32_t u = le_u32(p);
    float f;
    std::memcpy(&f, &u, sizeof f);
    return f;
}

// Parses one OBJ face index token ("7", "7/1/2", "-3") into a 0-based index.
inline long face_index(const std::string& tok, size_t vertex_count) {
    const long i = std::strtol(tok.c_str(), nullptr, 10);
    if (i > 0) return i - 1;
    if (i < 0) return static_cast<long>(vertex_count) + i;
    return -1;
}

inline scene::Mesh load_obj(const std::string& path) {
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

// The rays and the obvhs hits of a crosscheck directory.
struct RaySet {
    std::vector<Ray> rays;
    std::vector<RefHit> ref;
    uint32_t reflection_count = 0;
};

inline RaySet load_rays(const std::string& dir) {
    std::vector<unsigned char> rb, hb;
    if (!read_file(dir + "/rays.bin", rb)) die("cannot read " + dir + "/rays.bin");
    if (!read_file(dir + "/hits.bin", hb)) die("cannot read " + dir + "/hits.bin");
    if (rb.size() < 16 || std::memcmp(rb.data(), "REFLRAY1", 8) != 0) die("rays.bin: bad header");
    if (hb.size() < 12 || std::memcmp(hb.data(), "REFLHIT1", 8) != 0) die("hits.bin: bad header");
    const uint32_t count = le_u32(rb.data() + 8);
    RaySet s;
    s.reflection_count = le_u32(rb.data() + 12);
    if (rb.size() != 16 + size_t(count) * 32) die("rays.bin: size does not match its count");
    if (le_u32(hb.data() + 8) != count) die("hits.bin: count differs from rays.bin");
    if (hb.size() != 12 + size_t(count) * 16) die("hits.bin: size does not match its count");
    if (s.reflection_count > count) die("rays.bin: reflection_count > count");
    s.rays.resize(count);
    s.ref.resize(count);
    for (uint32_t i = 0; i < count; ++i) {
        const unsigned char* p = rb.data() + 16 + size_t(i) * 32;
        Ray& r = s.rays[i];
        for (int k = 0; k < 3; ++k) {
            r.o[k] = le_f32(p + 4 * k);
            r.d[k] = le_f32(p + 12 + 4 * k);
        }
        r.tmin = le_f32(p + 24);
        r.tmax = le_f32(p + 28);
        const unsigned char* q = hb.data() + 12 + size_t(i) * 16;
        s.ref[i] = {le_u32(q), le_f32(q + 4), le_f32(q + 8), le_f32(q + 12)};
    }
    return s;
}

// meta.txt as key -> value strings.
inline std::map<std::string, std::string> load_meta(const std::string& dir) {
    std::ifstream f(dir + "/meta.txt");
    if (!f) die("cannot open " + dir + "/meta.txt");
    std::map<std::string, std::string> m;
    std::string line;
    while (std::getline(f, line)) {
        const size_t eq = line.find(" = ");
        if (eq == std::string::npos) continue;
        m[line.substr(0, eq)] = line.substr(eq + 3);
    }
    return m;
}

inline const std::string& meta_get(const std::map<std::string, std::string>& m, const std::string& key) {
    const auto it = m.find(key);
    if (it == m.end()) die("meta.txt: no `" + key + "`");
    return it->second;
}

// The diagonal of the mesh's bounding box.
inline double diameter(const scene::Mesh& mesh) {
    double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
    for (size_t i = 0; i < mesh.vertices.size(); ++i) {
        lo[i % 3] = std::min(lo[i % 3], double(mesh.vertices[i]));
        hi[i % 3] = std::max(hi[i % 3], double(mesh.vertices[i]));
    }
    double s = 0.0;
    for (int k = 0; k < 3; ++k) s += (hi[k] - lo[k]) * (hi[k] - lo[k]);
    return std::sqrt(s);
}

}  // namespace crosscheck

#endif  // REFL_CPP_TESTS_CROSSCHECK_HPP
