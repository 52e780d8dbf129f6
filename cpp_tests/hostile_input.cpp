// hostile_input: every exported refl function, called with NULL pointers,
// zero and overflowing sizes, short buffers, misaligned pointers, NaN/Inf
// parameters, invalid cameras and planes and unknown enum values. Each call
// must return its documented status and leave its outputs byte-identical
// (outputs are prefilled with a sentinel pattern and compared after).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "check.hpp"
#include "refl.h"

namespace {

const float kNaN = std::numeric_limits<float>::quiet_NaN();
const float kInf = std::numeric_limits<float>::infinity();
constexpr uint32_t kMax = 0xFFFFFFFFu;
const uint32_t kBadConventions[] = {3u, 4u, 0x80000000u, kMax};

unsigned char pattern(size_t i) { return static_cast<unsigned char>(0xA5u ^ (i * 37u)); }

// An output slot of type T inside a sentinel-filled, 16-byte aligned buffer.
template <class T>
struct Slot {
    alignas(16) unsigned char bytes[sizeof(T) + 32];
    Slot() {
        for (size_t i = 0; i < sizeof(bytes); ++i) bytes[i] = pattern(i);
    }
    T* ptr() { return reinterpret_cast<T*>(bytes); }
    T* misaligned() { return reinterpret_cast<T*>(bytes + 1); }
    bool untouched() const {
        for (size_t i = 0; i < sizeof(bytes); ++i)
            if (bytes[i] != pattern(i)) return false;
        return true;
    }
};

// Calls f(out) with a sentinel-filled output, checks the status and that no
// output byte changed. Also calls f(nullptr) and f(misaligned) once per
// call site when `pointers` is set.
template <class T, class F>
void expect(const char* what, refl_status want, F f, bool pointers = true) {
    Slot<T> s;
    const uint32_t got = f(s.ptr());
    ++check::checks();
    if (got != static_cast<uint32_t>(want) || !s.untouched()) {
        check::fail(__FILE__, __LINE__,
                    std::string(what) + ": got " + check::status_name(got) + ", expected " +
                        check::status_name(want) + (s.untouched() ? "" : ", and the output was written"));
    }
    if (pointers) {
        CHECK_STATUS(f(nullptr), REFL_STATUS_NULL_POINTER);
        if (alignof(T) > 1) {
            Slot<T> m;
            const uint32_t g = f(m.misaligned());
            CHECK(g == REFL_STATUS_INVALID_ARGUMENT || g == REFL_STATUS_NULL_POINTER ||
                  g == static_cast<uint32_t>(want));
            CHECK(m.untouched());
        }
    }
}

// Calls f(out) expecting success (so that the error checks are not vacuous).
template <class T, class F>
T expect_ok(const char* what, F f) {
    T out{};
    const uint32_t got = f(&out);
    ++check::checks();
    if (got != REFL_STATUS_OK)
        check::fail(__FILE__, __LINE__, std::string(what) + ": " + check::status_name(got));
    return out;
}

refl_vec3 v3(float x, float y, float z) { return {x, y, z}; }
refl_vec2 v2(float x, float y) { return {x, y}; }

refl_camera good_camera() {
    refl_camera c;
    REQUIRE(refl_camera_look_at(&c, v3(1, 2, 5), v3(0, 0.5f, 0), v3(0, 1, 0), 1.0f, 0.1f, 100.0f, 64, 48) ==
            REFL_STATUS_OK);
    return c;
}

struct BadCamera {
    const char* name;
    refl_camera cam;
    refl_status status;
};

std::vector<BadCamera> bad_cameras() {
    const refl_camera g = good_camera();
    std::vector<BadCamera> v;
    auto add = [&](const char* name, refl_status st, auto edit) {
        refl_camera c = g;
        edit(c);
        v.push_back({name, c, st});
    };
    add("fov NaN", REFL_STATUS_INVALID_ARGUMENT, [](refl_camera& c) { c.fov_y = kNaN; });
    add("fov 0", REFL_STATUS_INVALID_ARGUMENT, [](refl_camera& c) { c.fov_y = 0.0f; });
    add("fov pi", REFL_STATUS_INVALID_ARGUMENT, [](refl_camera& c) { c.fov_y = 3.14159275f; });
    add("fov inf", REFL_STATUS_INVALID_ARGUMENT, [](refl_camera& c) { c.fov_y = kInf; });
    add("near 0", REFL_STATUS_INVALID_ARGUMENT, [](refl_camera& c) { c.z_near = 0.0f; });
    add("near -1", REFL_STATUS_INVALID_ARGUMENT, [](refl_camera& c) { c.z_near = -1.0f; });
    add("near inf", REFL_STATUS_INVALID_ARGUMENT, [](refl_camera& c) { c.z_near = kInf; });
    add("near NaN", REFL_STATUS_INVALID_ARGUMENT, [](refl_camera& c) { c.z_near = kNaN; });
    add("far == near", REFL_STATUS_INVALID_ARGUMENT, [](refl_camera& c) { c.z_far = c.z_near; });
    add("far NaN", REFL_STATUS_INVALID_ARGUMENT, [](refl_camera& c) { c.z_far = kNaN; });
    add("far -inf", REFL_STATUS_INVALID_ARGUMENT, [](refl_camera& c) { c.z_far = -kInf; });
    add("width 0", REFL_STATUS_INVALID_ARGUMENT, [](refl_camera& c) { c.width = 0; });
    add("height 0", REFL_STATUS_INVALID_ARGUMENT, [](refl_camera& c) { c.height = 0; });
    add("view NaN", REFL_STATUS_INVALID_ARGUMENT, [](refl_camera& c) { c.view.m[13] = kNaN; });
    add("view inf", REFL_STATUS_INVALID_ARGUMENT, [](refl_camera& c) { c.view.m[0] = kInf; });
    add("view scaled", REFL_STATUS_DEGENERATE_GEOMETRY, [](refl_camera& c) {
        for (int i = 0; i < 11; ++i) c.view.m[i] *= 2.0f;
    });
    add("view sheared", REFL_STATUS_DEGENERATE_GEOMETRY, [](refl_camera& c) { c.view.m[4] += 0.01f; });
    add("view projective row", REFL_STATUS_DEGENERATE_GEOMETRY, [](refl_camera& c) { c.view.m[3] = 0.25f; });
    add("view w = 2", REFL_STATUS_DEGENERATE_GEOMETRY, [](refl_camera& c) { c.view.m[15] = 2.0f; });
    add("view zero", REFL_STATUS_DEGENERATE_GEOMETRY, [](refl_camera& c) {
        for (int i = 0; i < 15; ++i) c.view.m[i] = 0.0f;
    });
    add("all bytes 0xFF", REFL_STATUS_INVALID_ARGUMENT,
        [](refl_camera& c) { std::memset(static_cast<void*>(&c), 0xFF, sizeof c); });
    add("all bytes 0", REFL_STATUS_INVALID_ARGUMENT,
        [](refl_camera& c) { std::memset(static_cast<void*>(&c), 0, sizeof c); });
    return v;
}

const refl_vec3 kBadVec3[] = {v3(kNaN, 0, 0), v3(0, kInf, 0), v3(0, 0, -kInf), v3(kNaN, kNaN, kNaN)};
const refl_vec2 kBadVec2[] = {v2(kNaN, 0), v2(0, kNaN), v2(kInf, 0), v2(0, -kInf)};

void status_strings() {
    for (uint32_t v = 0; v < 4096; ++v) CHECK(refl_status_string(v) != nullptr);
    for (uint32_t v : {0x7FFFFFFFu, 0x80000000u, kMax, kMax - 1}) {
        CHECK(refl_status_string(v) != nullptr);
        CHECK(std::strlen(refl_status_string(v)) > 0);
    }
    for (uint32_t a = 0; a <= REFL_STATUS_PANIC; ++a)
        for (uint32_t b = a + 1; b <= REFL_STATUS_PANIC + 1; ++b)
            CHECK(std::strcmp(refl_status_string(a), refl_status_string(b)) != 0);
    CHECK(refl_version() != nullptr && std::strlen(refl_version()) >= 5);
    CHECK_EQ(refl_version_number(), uint32_t((REFL_VERSION_MAJOR << 16) | (REFL_VERSION_MINOR << 8) | REFL_VERSION_PATCH));
}

void camera_functions() {
    const refl_camera g = good_camera();
    const std::vector<BadCamera> bad = bad_cameras();
    const refl_vec3 p = v3(0.1f, 0.2f, 0.3f);
    const refl_vec2 px = v2(10.5f, 20.5f);

    // refl_camera_look_at
    auto look = [](refl_vec3 e, refl_vec3 t, refl_vec3 u, float fov, float n, float f, uint32_t w, uint32_t h) {
        return [=](refl_camera* o) { return refl_camera_look_at(o, e, t, u, fov, n, f, w, h); };
    };
    const refl_vec3 e = v3(0, 1, 5), t = v3(0, 0, 0), up = v3(0, 1, 0);
    expect_ok<refl_camera>("look_at", look(e, t, up, 1, 0.1f, kInf, kMax, kMax));
    for (refl_vec3 b : kBadVec3) {
        expect<refl_camera>("look_at bad eye", REFL_STATUS_INVALID_ARGUMENT, look(b, t, up, 1, 0.1f, 10, 4, 4));
        expect<refl_camera>("look_at bad target", REFL_STATUS_INVALID_ARGUMENT, look(e, b, up, 1, 0.1f, 10, 4, 4));
        expect<refl_camera>("look_at bad up", REFL_STATUS_INVALID_ARGUMENT, look(e, t, b, 1, 0.1f, 10, 4, 4));
    }
    expect<refl_camera>("look_at eye == target", REFL_STATUS_DEGENERATE_GEOMETRY, look(e, e, up, 1, 0.1f, 10, 4, 4));
    expect<refl_camera>("look_at up parallel", REFL_STATUS_DEGENERATE_GEOMETRY,
                        look(v3(0, 5, 0), t, up, 1, 0.1f, 10, 4, 4));
    expect<refl_camera>("look_at zero up", REFL_STATUS_DEGENERATE_GEOMETRY, look(e, t, v3(0, 0, 0), 1, 0.1f, 10, 4, 4));
    // The view's translation overflows float.
    expect<refl_camera>("look_at far eye", REFL_STATUS_INVALID_ARGUMENT,
                        look(v3(3e38f, 3e38f, 0), v3(-3e38f, -3e38f, 0), up, 1, 0.1f, 10, 4, 4));
    for (float fov : {0.0f, -1.0f, 3.2f, kNaN, kInf})
        expect<refl_camera>("look_at fov", REFL_STATUS_INVALID_ARGUMENT, look(e, t, up, fov, 0.1f, 10, 4, 4));
    for (float n : {0.0f, -0.1f, kNaN, kInf, -kInf})
        expect<refl_camera>("look_at near", REFL_STATUS_INVALID_ARGUMENT, look(e, t, up, 1, n, 10, 4, 4));
    for (float f : {0.1f, 0.05f, kNaN, -kInf})
        expect<refl_camera>("look_at far", REFL_STATUS_INVALID_ARGUMENT, look(e, t, up, 1, 0.1f, f, 4, 4));
    expect<refl_camera>("look_at width 0", REFL_STATUS_INVALID_ARGUMENT, look(e, t, up, 1, 0.1f, 10, 0, 4));
    expect<refl_camera>("look_at height 0", REFL_STATUS_INVALID_ARGUMENT, look(e, t, up, 1, 0.1f, 10, 4, 0));

    // refl_camera_validate
    CHECK_STATUS(refl_camera_validate(&g), REFL_STATUS_OK);
    CHECK_STATUS(refl_camera_validate(nullptr), REFL_STATUS_NULL_POINTER);
    for (const BadCamera& b : bad) CHECK_STATUS(refl_camera_validate(&b.cam), b.status);
    {
        alignas(16) unsigned char raw[sizeof(refl_camera) + 8];
        std::memcpy(raw + 2, &g, sizeof g);
        CHECK_STATUS(refl_camera_validate(reinterpret_cast<const refl_camera*>(raw + 2)),
                     REFL_STATUS_INVALID_ARGUMENT);
    }

    // Every function taking one camera: NULL camera, each bad camera.
    auto per_camera = [&](const char* name, auto call_with) {
        call_with(&g, REFL_STATUS_OK, name, true);
        call_with(nullptr, REFL_STATUS_NULL_POINTER, name, false);
        for (const BadCamera& b : bad) call_with(&b.cam, b.status, b.name, false);
    };
    per_camera("primary_ray", [&](const refl_camera* c, refl_status st, const char* n, bool okay) {
        if (okay) expect_ok<refl_ray>(n, [&](refl_ray* o) { return refl_camera_primary_ray(o, c, px); });
        else expect<refl_ray>(n, st, [&](refl_ray* o) { return refl_camera_primary_ray(o, c, px); });
    });
    per_camera("project", [&](const refl_camera* c, refl_status st, const char* n, bool okay) {
        if (okay) expect_ok<refl_projection>(n, [&](refl_projection* o) { return refl_camera_project(o, c, p); });
        else expect<refl_projection>(n, st, [&](refl_projection* o) { return refl_camera_project(o, c, p); });
    });
    per_camera("linear_depth", [&](const refl_camera* c, refl_status st, const char* n, bool okay) {
        auto f = [&](float* o) { return refl_camera_linear_depth(o, c, p); };
        if (okay) expect_ok<float>(n, f);
        else expect<float>(n, st, f);
    });
    per_camera("unproject", [&](const refl_camera* c, refl_status st, const char* n, bool okay) {
        auto f = [&](refl_vec3* o) { return refl_camera_unproject(o, c, px, 0.5f, REFL_DEPTH_CONVENTION_ZERO_TO_ONE); };
        if (okay) expect_ok<refl_vec3>(n, f);
        else expect<refl_vec3>(n, st, f);
    });
    per_camera("encode_depth", [&](const refl_camera* c, refl_status st, const char* n, bool okay) {
        auto f = [&](float* o) { return refl_camera_encode_depth(o, c, 2.0f, REFL_DEPTH_CONVENTION_REVERSED_Z); };
        if (okay) expect_ok<float>(n, f);
        else expect<float>(n, st, f);
    });
    per_camera("decode_depth", [&](const refl_camera* c, refl_status st, const char* n, bool okay) {
        auto f = [&](float* o) { return refl_camera_decode_depth(o, c, 0.5f, REFL_DEPTH_CONVENTION_REVERSED_Z); };
        if (okay) expect_ok<float>(n, f);
        else expect<float>(n, st, f);
    });
    per_camera("projection_matrix", [&](const refl_camera* c, refl_status st, const char* n, bool okay) {
        auto f = [&](refl_mat4* o) { return refl_camera_projection_matrix(o, c, REFL_DEPTH_CONVENTION_ZERO_TO_ONE); };
        if (okay) expect_ok<refl_mat4>(n, f);
        else expect<refl_mat4>(n, st, f);
    });
    per_camera("world_to_pixel_matrix", [&](const refl_camera* c, refl_status st, const char* n, bool okay) {
        auto f = [&](refl_mat4* o) {
            return refl_camera_world_to_pixel_matrix(o, c, REFL_DEPTH_CONVENTION_REVERSED_Z);
        };
        if (okay) expect_ok<refl_mat4>(n, f);
        else expect<refl_mat4>(n, st, f);
    });
    per_camera("inverse_view", [&](const refl_camera* c, refl_status st, const char* n, bool okay) {
        auto f = [&](refl_mat4* o) { return refl_camera_inverse_view(o, c); };
        if (okay) expect_ok<refl_mat4>(n, f);
        else expect<refl_mat4>(n, st, f);
    });
    per_camera("eye", [&](const refl_camera* c, refl_status st, const char* n, bool okay) {
        auto f = [&](refl_vec3* o) { return refl_camera_eye(o, c); };
        if (okay) expect_ok<refl_vec3>(n, f);
        else expect<refl_vec3>(n, st, f);
    });
    per_camera("is_mirrored", [&](const refl_camera* c, refl_status st, const char* n, bool okay) {
        auto f = [&](bool* o) { return refl_camera_is_mirrored(o, c); };
        if (okay) expect_ok<bool>(n, f);
        else expect<bool>(n, st, f);
    });
    // Two-camera functions: a bad camera in either position.
    per_camera("reprojection_matrix", [&](const refl_camera* c, refl_status st, const char* n, bool okay) {
        auto f1 = [&](refl_mat4* o) { return refl_camera_reprojection_matrix(o, c, &g, REFL_DEPTH_CONVENTION_ZERO_TO_ONE); };
        auto f2 = [&](refl_mat4* o) { return refl_camera_reprojection_matrix(o, &g, c, REFL_DEPTH_CONVENTION_REVERSED_Z); };
        if (okay) {
            expect_ok<refl_mat4>(n, f1);
            expect_ok<refl_mat4>(n, f2);
        } else {
            expect<refl_mat4>(n, st, f1);
            expect<refl_mat4>(n, st, f2);
        }
    });
    per_camera("reproject", [&](const refl_camera* c, refl_status st, const char* n, bool okay) {
        auto f1 = [&](refl_projection* o) { return refl_camera_reproject(o, c, &g, px, 0.5f, REFL_DEPTH_CONVENTION_ZERO_TO_ONE); };
        auto f2 = [&](refl_projection* o) { return refl_camera_reproject(o, &g, c, px, 3.0f, REFL_DEPTH_CONVENTION_LINEAR); };
        if (okay) {
            expect_ok<refl_projection>(n, f1);
            expect_ok<refl_projection>(n, f2);
        } else {
            expect<refl_projection>(n, st, f1);
            expect<refl_projection>(n, st, f2);
        }
    });

    // NaN/Inf parameters with a good camera.
    for (refl_vec2 b : kBadVec2) {
        expect<refl_ray>("primary_ray pixel", REFL_STATUS_INVALID_ARGUMENT,
                         [&](refl_ray* o) { return refl_camera_primary_ray(o, &g, b); });
        expect<refl_vec3>("unproject pixel", REFL_STATUS_INVALID_ARGUMENT,
                          [&](refl_vec3* o) { return refl_camera_unproject(o, &g, b, 0.5f, 1); });
        expect<refl_projection>("reproject pixel", REFL_STATUS_INVALID_ARGUMENT,
                                [&](refl_projection* o) { return refl_camera_reproject(o, &g, &g, b, 0.5f, 1); });
    }
    expect<refl_ray>("primary_ray huge pixel", REFL_STATUS_INVALID_ARGUMENT,
                     [&](refl_ray* o) { return refl_camera_primary_ray(o, &g, v2(3e38f, -3e38f)); });
    for (refl_vec3 b : kBadVec3) {
        expect<refl_projection>("project point", REFL_STATUS_INVALID_ARGUMENT,
                                [&](refl_projection* o) { return refl_camera_project(o, &g, b); });
        expect<float>("linear_depth point", REFL_STATUS_INVALID_ARGUMENT,
                      [&](float* o) { return refl_camera_linear_depth(o, &g, b); });
    }
    for (float d : {kNaN, kInf, -kInf}) {
        expect<refl_vec3>("unproject depth", REFL_STATUS_INVALID_ARGUMENT,
                          [&](refl_vec3* o) { return refl_camera_unproject(o, &g, px, d, 0); });
        expect<refl_projection>("reproject depth", REFL_STATUS_INVALID_ARGUMENT,
                                [&](refl_projection* o) { return refl_camera_reproject(o, &g, &g, px, d, 0); });
    }
    expect<float>("encode NaN", REFL_STATUS_INVALID_ARGUMENT,
                  [&](float* o) { return refl_camera_encode_depth(o, &g, kNaN, 1); });
    expect<float>("decode NaN", REFL_STATUS_INVALID_ARGUMENT,
                  [&](float* o) { return refl_camera_decode_depth(o, &g, kNaN, 2); });
    expect<float>("encode inf, finite far (inf/inf)", REFL_STATUS_INVALID_ARGUMENT,
                  [&](float* o) { return refl_camera_encode_depth(o, &g, kInf, 1); });
    // Unknown conventions.
    for (uint32_t c : kBadConventions) {
        expect<refl_vec3>("unproject convention", REFL_STATUS_INVALID_ARGUMENT,
                          [&](refl_vec3* o) { return refl_camera_unproject(o, &g, px, 0.5f, c); });
        expect<float>("encode convention", REFL_STATUS_INVALID_ARGUMENT,
                      [&](float* o) { return refl_camera_encode_depth(o, &g, 1.0f, c); });
        expect<float>("decode convention", REFL_STATUS_INVALID_ARGUMENT,
                      [&](float* o) { return refl_camera_decode_depth(o, &g, 0.5f, c); });
        expect<refl_mat4>("projection convention", REFL_STATUS_INVALID_ARGUMENT,
                          [&](refl_mat4* o) { return refl_camera_projection_matrix(o, &g, c); });
        expect<refl_mat4>("world_to_pixel convention", REFL_STATUS_INVALID_ARGUMENT,
                          [&](refl_mat4* o) { return refl_camera_world_to_pixel_matrix(o, &g, c); });
        expect<refl_mat4>("reprojection convention", REFL_STATUS_INVALID_ARGUMENT,
                          [&](refl_mat4* o) { return refl_camera_reprojection_matrix(o, &g, &g, c); });
        expect<refl_projection>("reproject convention", REFL_STATUS_INVALID_ARGUMENT,
                                [&](refl_projection* o) { return refl_camera_reproject(o, &g, &g, px, 0.5f, c); });
    }
    // LINEAR is not projective.
    expect<refl_mat4>("projection LINEAR", REFL_STATUS_INVALID_ARGUMENT,
                      [&](refl_mat4* o) { return refl_camera_projection_matrix(o, &g, REFL_DEPTH_CONVENTION_LINEAR); });
    expect<refl_mat4>("world_to_pixel LINEAR", REFL_STATUS_INVALID_ARGUMENT, [&](refl_mat4* o) {
        return refl_camera_world_to_pixel_matrix(o, &g, REFL_DEPTH_CONVENTION_LINEAR);
    });
    expect<refl_mat4>("reprojection LINEAR", REFL_STATUS_INVALID_ARGUMENT, [&](refl_mat4* o) {
        return refl_camera_reprojection_matrix(o, &g, &g, REFL_DEPTH_CONVENTION_LINEAR);
    });
    // The far plane at infinity has no finite point.
    refl_camera inf_far = g;
    inf_far.z_far = kInf;
    expect<refl_vec3>("unproject infinite far", REFL_STATUS_INVALID_ARGUMENT, [&](refl_vec3* o) {
        return refl_camera_unproject(o, &inf_far, px, 0.0f, REFL_DEPTH_CONVENTION_REVERSED_Z);
    });

    // refl_camera_apply_reprojection
    const refl_mat4 m = expect_ok<refl_mat4>("reprojection_matrix", [&](refl_mat4* o) {
        return refl_camera_reprojection_matrix(o, &g, &g, REFL_DEPTH_CONVENTION_ZERO_TO_ONE);
    });
    expect_ok<refl_projection>("apply", [&](refl_projection* o) { return refl_camera_apply_reprojection(o, &m, px, 0.5f); });
    expect<refl_projection>("apply NULL matrix", REFL_STATUS_NULL_POINTER,
                            [&](refl_projection* o) { return refl_camera_apply_reprojection(o, nullptr, px, 0.5f); });
    for (int i = 0; i < 16; i += 5) {
        refl_mat4 bm = m;
        bm.m[i] = (i % 2) ? kInf : kNaN;
        expect<refl_projection>("apply bad matrix", REFL_STATUS_INVALID_ARGUMENT,
                                [&](refl_projection* o) { return refl_camera_apply_reprojection(o, &bm, px, 0.5f); });
    }
    for (refl_vec2 b : kBadVec2)
        expect<refl_projection>("apply pixel", REFL_STATUS_INVALID_ARGUMENT,
                                [&](refl_projection* o) { return refl_camera_apply_reprojection(o, &m, b, 0.5f); });
    for (float d : {kNaN, kInf})
        expect<refl_projection>("apply depth", REFL_STATUS_INVALID_ARGUMENT,
                                [&](refl_projection* o) { return refl_camera_apply_reprojection(o, &m, px, d); });
}

void plane_functions() {
    const refl_camera g = good_camera();
    const refl_plane good = expect_ok<refl_plane>("from_point_normal", [](refl_plane* o) {
        return refl_plane_from_point_normal(o, v3(0, 0, 0), v3(0, 1, 0));
    });
    const refl_ray ray{v3(0, 5, 0), v3(0, -1, 0)};

    // Construction.
    for (refl_vec3 b : kBadVec3) {
        expect<refl_plane>("triangle p1", REFL_STATUS_INVALID_ARGUMENT,
                           [&](refl_plane* o) { return refl_plane_from_triangle(o, b, v3(1, 0, 0), v3(0, 0, 1)); });
        expect<refl_plane>("triangle p3", REFL_STATUS_INVALID_ARGUMENT,
                           [&](refl_plane* o) { return refl_plane_from_triangle(o, v3(0, 0, 0), v3(1, 0, 0), b); });
        expect<refl_plane>("point_normal point", REFL_STATUS_INVALID_ARGUMENT,
                           [&](refl_plane* o) { return refl_plane_from_point_normal(o, b, v3(0, 1, 0)); });
        expect<refl_plane>("point_normal normal", REFL_STATUS_INVALID_ARGUMENT,
                           [&](refl_plane* o) { return refl_plane_from_point_normal(o, v3(0, 0, 0), b); });
        expect<refl_vec3>("reflect v", REFL_STATUS_INVALID_ARGUMENT,
                          [&](refl_vec3* o) { return refl_mirror_reflect(o, b, v3(0, 1, 0)); });
        expect<refl_vec3>("reflect n", REFL_STATUS_INVALID_ARGUMENT,
                          [&](refl_vec3* o) { return refl_mirror_reflect(o, v3(0, 1, 0), b); });
    }
    expect<refl_plane>("triangle zero area", REFL_STATUS_DEGENERATE_GEOMETRY,
                       [&](refl_plane* o) { return refl_plane_from_triangle(o, v3(1, 1, 1), v3(1, 1, 1), v3(1, 1, 1)); });
    expect<refl_plane>("triangle collinear", REFL_STATUS_DEGENERATE_GEOMETRY,
                       [&](refl_plane* o) { return refl_plane_from_triangle(o, v3(0, 0, 0), v3(1, 2, 3), v3(2, 4, 6)); });
    expect<refl_plane>("triangle sliver", REFL_STATUS_DEGENERATE_GEOMETRY, [&](refl_plane* o) {
        return refl_plane_from_triangle(o, v3(0, 0, 0), v3(1e4f, 0, 0), v3(2e4f, 1e-6f, 0));
    });
    expect<refl_plane>("point_normal zero normal", REFL_STATUS_DEGENERATE_GEOMETRY,
                       [&](refl_plane* o) { return refl_plane_from_point_normal(o, v3(0, 0, 0), v3(0, 0, 0)); });
    expect<refl_vec3>("reflect overflow", REFL_STATUS_INVALID_ARGUMENT,
                      [&](refl_vec3* o) { return refl_mirror_reflect(o, v3(3e38f, 3e38f, 0), v3(1, 1, 0)); });
    expect_ok<refl_vec3>("reflect", [&](refl_vec3* o) { return refl_mirror_reflect(o, v3(0, 1, 0), v3(0, 1, 0)); });
    // A zero normal has no reflection (it used to return OK with -v); a
    // non-unit one is refused rather than silently scaling the result.
    expect<refl_vec3>("reflect zero normal", REFL_STATUS_DEGENERATE_GEOMETRY,
                      [&](refl_vec3* o) { return refl_mirror_reflect(o, v3(1, 1, 0), v3(0, 0, 0)); });
    expect<refl_vec3>("reflect non-unit normal", REFL_STATUS_INVALID_ARGUMENT,
                      [&](refl_vec3* o) { return refl_mirror_reflect(o, v3(1, 1, 0), v3(0, 2, 0)); });
    {
        refl_vec3 o{};
        CHECK_STATUS(refl_mirror_reflect(&o, v3(1, 1, 0), v3(0, 0, 0)), REFL_STATUS_DEGENERATE_GEOMETRY);
        char msg[128];
        refl_last_error_message(msg, sizeof msg);
        CHECK(std::strstr(msg, "refl_mirror_reflect: degenerate geometry: `n` is the zero vector") == msg);
    }

    // Functions taking a plane: NULL, non-finite and zero-normal planes.
    struct BadPlane {
        refl_plane p;
        refl_status st;
    };
    const BadPlane bad[] = {
        {{v3(0, 0, 0), 0.0f}, REFL_STATUS_DEGENERATE_GEOMETRY},
        {{v3(0, 1, 0), kNaN}, REFL_STATUS_INVALID_ARGUMENT},
        {{v3(0, 1, 0), kInf}, REFL_STATUS_INVALID_ARGUMENT},
        {{v3(kNaN, 1, 0), 0.0f}, REFL_STATUS_INVALID_ARGUMENT},
        {{v3(0, kInf, 0), 0.0f}, REFL_STATUS_INVALID_ARGUMENT},
    };
    auto per_plane = [&](const char* name, auto call) {
        call(&good, REFL_STATUS_OK, name);
        call(nullptr, REFL_STATUS_NULL_POINTER, name);
        for (const BadPlane& b : bad) call(&b.p, b.st, name);
    };
    per_plane("signed_distance", [&](const refl_plane* pl, refl_status st, const char* n) {
        auto f = [&](float* o) { return refl_plane_signed_distance(o, pl, v3(1, 2, 3)); };
        if (st == REFL_STATUS_OK) expect_ok<float>(n, f);
        else expect<float>(n, st, f);
    });
    per_plane("intersect_ray", [&](const refl_plane* pl, refl_status st, const char* n) {
        auto f = [&](float* o) { return refl_plane_intersect_ray(o, pl, ray); };
        if (st == REFL_STATUS_OK) expect_ok<float>(n, f);
        else expect<float>(n, st, f);
    });
    per_plane("mirror_matrix", [&](const refl_plane* pl, refl_status st, const char* n) {
        auto f = [&](refl_mat4* o) { return refl_mirror_matrix(o, pl); };
        if (st == REFL_STATUS_OK) expect_ok<refl_mat4>(n, f);
        else expect<refl_mat4>(n, st, f);
    });
    per_plane("mirror_point", [&](const refl_plane* pl, refl_status st, const char* n) {
        auto f = [&](refl_vec3* o) { return refl_mirror_point(o, pl, v3(1, 2, 3)); };
        if (st == REFL_STATUS_OK) expect_ok<refl_vec3>(n, f);
        else expect<refl_vec3>(n, st, f);
    });
    per_plane("mirrored_camera", [&](const refl_plane* pl, refl_status st, const char* n) {
        auto f = [&](refl_camera* o) { return refl_mirror_camera(o, &g, pl); };
        if (st == REFL_STATUS_OK) expect_ok<refl_camera>(n, f);
        else expect<refl_camera>(n, st, f);
    });
    for (const BadCamera& b : bad_cameras())
        expect<refl_camera>(b.name, b.status, [&](refl_camera* o) { return refl_mirror_camera(o, &b.cam, &good); });
    expect<refl_camera>("mirrored NULL camera", REFL_STATUS_NULL_POINTER,
                        [&](refl_camera* o) { return refl_mirror_camera(o, nullptr, &good); });
    // Oblique near plane: the mirrored camera with the mirror plane is valid;
    // the real camera has its eye on the kept side.
    refl_camera mirrored;
    REQUIRE(refl_mirror_camera(&mirrored, &g, &good) == REFL_STATUS_OK);
    per_plane("oblique_projection", [&](const refl_plane* pl, refl_status st, const char* n) {
        auto f = [&](refl_mat4* o) {
            return refl_mirror_oblique_projection(o, &mirrored, pl, REFL_DEPTH_CONVENTION_REVERSED_Z);
        };
        if (st == REFL_STATUS_OK) expect_ok<refl_mat4>(n, f);
        else expect<refl_mat4>(n, st, f);
    });
    for (const BadCamera& b : bad_cameras())
        expect<refl_mat4>(b.name, b.status, [&](refl_mat4* o) {
            return refl_mirror_oblique_projection(o, &b.cam, &good, REFL_DEPTH_CONVENTION_ZERO_TO_ONE);
        });
    expect<refl_mat4>("oblique NULL camera", REFL_STATUS_NULL_POINTER, [&](refl_mat4* o) {
        return refl_mirror_oblique_projection(o, nullptr, &good, REFL_DEPTH_CONVENTION_ZERO_TO_ONE);
    });
    for (uint32_t c : {uint32_t(REFL_DEPTH_CONVENTION_LINEAR), 3u, 0xFFFFFFFFu})
        expect<refl_mat4>("oblique convention", REFL_STATUS_INVALID_ARGUMENT,
                          [&](refl_mat4* o) { return refl_mirror_oblique_projection(o, &mirrored, &good, c); });
    expect<refl_mat4>("oblique eye on the kept side", REFL_STATUS_DEGENERATE_GEOMETRY, [&](refl_mat4* o) {
        return refl_mirror_oblique_projection(o, &g, &good, REFL_DEPTH_CONVENTION_ZERO_TO_ONE);
    });
    for (refl_vec3 b : kBadVec3) {
        expect<float>("signed_distance point", REFL_STATUS_INVALID_ARGUMENT,
                      [&](float* o) { return refl_plane_signed_distance(o, &good, b); });
        expect<refl_vec3>("mirror_point point", REFL_STATUS_INVALID_ARGUMENT,
                          [&](refl_vec3* o) { return refl_mirror_point(o, &good, b); });
        expect<float>("intersect origin", REFL_STATUS_INVALID_ARGUMENT,
                      [&](float* o) { return refl_plane_intersect_ray(o, &good, refl_ray{b, v3(0, 1, 0)}); });
        expect<float>("intersect dir", REFL_STATUS_INVALID_ARGUMENT,
                      [&](float* o) { return refl_plane_intersect_ray(o, &good, refl_ray{v3(0, 1, 0), b}); });
    }
    expect<float>("intersect parallel", REFL_STATUS_DEGENERATE_GEOMETRY,
                  [&](float* o) { return refl_plane_intersect_ray(o, &good, refl_ray{v3(0, 1, 0), v3(1, 0, 0)}); });
    expect<float>("intersect zero dir", REFL_STATUS_DEGENERATE_GEOMETRY,
                  [&](float* o) { return refl_plane_intersect_ray(o, &good, refl_ray{v3(0, 1, 0), v3(0, 0, 0)}); });
    expect<refl_vec3>("mirror_point overflow", REFL_STATUS_INVALID_ARGUMENT,
                      [&](refl_vec3* o) { return refl_mirror_point(o, &good, v3(0, 3e38f, 0)); });
    // A camera so far away that its mirrored view overflows float.
    refl_camera far_cam;
    REQUIRE(refl_camera_look_at(&far_cam, v3(0, 1e38f, 0), v3(1e37f, 0, 0), v3(0, 0, 1), 1.0f, 0.1f, kInf, 4, 4) ==
            REFL_STATUS_OK);
    const refl_plane offset{v3(0, 1, 0), 3e38f};
    expect<refl_camera>("mirrored overflow", REFL_STATUS_INVALID_ARGUMENT,
                        [&](refl_camera* o) { return refl_mirror_camera(o, &far_cam, &offset); });
}

// An image buffer with padding, prefilled with distinct values;
// `untouched` compares every byte with the prefill.
struct Buffer {
    std::vector<float> data, original;
    explicit Buffer(size_t n) : data(n) {
        for (size_t i = 0; i < n; ++i) data[i] = -1000.0f - static_cast<float>(i);
        original = data;
    }
    bool untouched() const { return std::memcmp(data.data(), original.data(), data.size() * sizeof(float)) == 0; }
};

void image_functions() {
    const refl_camera g = good_camera();

    // refl_image_required_len
    CHECK_EQ(expect_ok<size_t>("required_len", [](size_t* o) { return refl_image_required_len(o, 4, 3, 6); }),
             size_t(16));
    if (sizeof(size_t) == 8) {
        const size_t big = expect_ok<size_t>("required_len max",
                                             [](size_t* o) { return refl_image_required_len(o, kMax, kMax, kMax); });
        CHECK_EQ(big, size_t(0xFFFFFFFFull * 0xFFFFFFFEull + 0xFFFFFFFFull));
    }
    const uint32_t bad_sizes[][3] = {{0, 1, 1}, {1, 0, 1}, {0, 0, 0}, {4, 4, 3}, {kMax, 1, kMax - 1}, {kMax, kMax, 0}};
    for (const auto& s : bad_sizes)
        expect<size_t>("required_len bad", REFL_STATUS_INVALID_ARGUMENT,
                       [&](size_t* o) { return refl_image_required_len(o, s[0], s[1], s[2]); });

    // refl_image_row_band
    const refl_row_range band =
        expect_ok<refl_row_range>("row_band", [](refl_row_range* o) { return refl_image_row_band(o, 10, 3, 4); });
    CHECK(band.begin == 8 && band.end == 10);
    const refl_row_range empty =
        expect_ok<refl_row_range>("row_band empty", [](refl_row_range* o) { return refl_image_row_band(o, 2, 3, 4); });
    CHECK(empty.begin == empty.end);
    const uint32_t bad_bands[][3] = {{0, 0, 1}, {4, 0, 0}, {4, 1, 1}, {4, kMax, kMax}, {kMax, 5, 5}};
    for (const auto& b : bad_bands)
        expect<refl_row_range>("row_band bad", REFL_STATUS_INVALID_ARGUMENT,
                               [&](refl_row_range* o) { return refl_image_row_band(o, b[0], b[1], b[2]); });

    // refl_image_convert_depth: dst is the output; it must stay untouched on error.
    const uint32_t w = 5, h = 4, stride = 7;
    const size_t len = size_t(h - 1) * stride + w;  // 26
    std::vector<float> src_data(len, 0.5f);
    const refl_image_f32 src{src_data.data(), len, w, h, stride};
    auto run = [&](const char* what, refl_status want, auto make_call) {
        Buffer dst(64);
        const refl_image_f32_mut d{dst.data.data(), len, w, h, stride};
        const uint32_t got = make_call(d);
        ++check::checks();
        if (got != static_cast<uint32_t>(want) || !dst.untouched())
            check::fail(__FILE__, __LINE__,
                        std::string("convert_depth ") + what + ": got " + check::status_name(got) + ", expected " +
                            check::status_name(want) + (dst.untouched() ? "" : ", and dst was written"));
    };
    auto conv = [&](refl_image_f32 s, const refl_camera* c, uint32_t from, uint32_t to, uint32_t b, uint32_t e) {
        return [=](refl_image_f32_mut d) { return refl_image_convert_depth(d, s, c, from, to, refl_row_range{b, e}); };
    };
    {
        Buffer dst(64);
        const refl_image_f32_mut d{dst.data.data(), len, w, h, stride};
        CHECK_STATUS(refl_image_convert_depth(d, src, &g, 0, 1, refl_row_range{1, 3}), REFL_STATUS_OK);
        CHECK(!dst.untouched());
        CHECK(dst.data[stride - 1] == -1000.0f - float(stride - 1));  // padding untouched
        CHECK(dst.data[0] == -1000.0f);                                // row 0 outside the range
    }
    run("NULL camera", REFL_STATUS_NULL_POINTER, conv(src, nullptr, 0, 1, 0, h));
    run("NULL src", REFL_STATUS_NULL_POINTER, conv(refl_image_f32{nullptr, len, w, h, stride}, &g, 0, 1, 0, h));
    run("NULL dst", REFL_STATUS_NULL_POINTER, [&](refl_image_f32_mut d) {
        d.data = nullptr;
        return refl_image_convert_depth(d, src, &g, 0, 1, refl_row_range{0, h});
    });
    for (const BadCamera& b : bad_cameras()) run(b.name, b.status, conv(src, &b.cam, 0, 1, 0, h));
    for (uint32_t c : kBadConventions) {
        run("from", REFL_STATUS_INVALID_ARGUMENT, conv(src, &g, c, 1, 0, h));
        run("to", REFL_STATUS_INVALID_ARGUMENT, conv(src, &g, 1, c, 0, h));
    }
    const uint32_t bad_rows[][2] = {{0, 0}, {2, 2}, {3, 1}, {0, h + 1}, {h, h}, {0, kMax}, {kMax, kMax}};
    for (const auto& r : bad_rows) run("rows", REFL_STATUS_INVALID_ARGUMENT, conv(src, &g, 0, 1, r[0], r[1]));
    // Bad source descriptors.
    const struct {
        const char* what;
        refl_image_f32 img;
        refl_status st;
    } bad_src[] = {
        {"src width 0", {src_data.data(), len, 0, h, stride}, REFL_STATUS_INVALID_ARGUMENT},
        {"src height 0", {src_data.data(), len, w, 0, stride}, REFL_STATUS_INVALID_ARGUMENT},
        {"src stride < width", {src_data.data(), len, w, h, w - 1}, REFL_STATUS_INVALID_ARGUMENT},
        {"src size mismatch", {src_data.data(), len, w, h - 1, stride}, REFL_STATUS_INVALID_ARGUMENT},
        {"src 0xFFFFFFFF^2, len SIZE_MAX", {src_data.data(), SIZE_MAX, kMax, kMax, kMax}, REFL_STATUS_INVALID_ARGUMENT},
        {"src 0xFFFFFFFF^2, short", {src_data.data(), len, kMax, kMax, kMax}, REFL_STATUS_INSUFFICIENT_SIZE},
        {"src short", {src_data.data(), len - 1, w, h, stride}, REFL_STATUS_INSUFFICIENT_SIZE},
        {"src len 0", {src_data.data(), 0, w, h, stride}, REFL_STATUS_INSUFFICIENT_SIZE},
        {"src misaligned",
         {reinterpret_cast<const float*>(reinterpret_cast<const unsigned char*>(src_data.data()) + 1), len - 1, w, h,
          stride},
         REFL_STATUS_INVALID_ARGUMENT},
    };
    for (const auto& b : bad_src) run(b.what, b.st, conv(b.img, &g, 0, 1, 0, h));
    // Bad destination descriptors.
    auto with_dst = [&](auto edit) {
        return [=](refl_image_f32_mut d) {
            edit(d);
            return refl_image_convert_depth(d, src, &g, 0, 1, refl_row_range{0, h});
        };
    };
    run("dst short", REFL_STATUS_INSUFFICIENT_SIZE, with_dst([](refl_image_f32_mut& d) { d.len -= 1; }));
    run("dst stride < width", REFL_STATUS_INVALID_ARGUMENT, with_dst([](refl_image_f32_mut& d) { d.stride = 2; }));
    run("dst width 0", REFL_STATUS_INVALID_ARGUMENT, with_dst([](refl_image_f32_mut& d) { d.width = 0; }));
    run("dst size mismatch", REFL_STATUS_INVALID_ARGUMENT, with_dst([](refl_image_f32_mut& d) { d.width = 4; }));
    run("dst overflowing", REFL_STATUS_INVALID_ARGUMENT, with_dst([](refl_image_f32_mut& d) {
            d.width = d.height = d.stride = kMax;
            d.len = SIZE_MAX;
        }));
    run("dst misaligned", REFL_STATUS_INVALID_ARGUMENT, with_dst([](refl_image_f32_mut& d) {
            d.data = reinterpret_cast<float*>(reinterpret_cast<unsigned char*>(d.data) + 2);
            d.len -= 1;
        }));
    // Overlap: src one texel into dst, or the same memory with another stride.
    run("partial overlap", REFL_STATUS_INVALID_ARGUMENT, [&](refl_image_f32_mut d) {
        return refl_image_convert_depth(d, refl_image_f32{d.data + 1, len, w, h, stride}, &g, 0, 1, refl_row_range{0, h});
    });
    run("same memory, other stride", REFL_STATUS_INVALID_ARGUMENT, [&](refl_image_f32_mut d) {
        return refl_image_convert_depth(d, refl_image_f32{d.data, 64, w, h, stride + 1}, &g, 0, 1, refl_row_range{0, h});
    });
    // In place is allowed.
    {
        Buffer dst(64);
        const refl_image_f32_mut d{dst.data.data(), len, w, h, stride};
        for (size_t i = 0; i < len; ++i) dst.data[i] = 2.0f;
        CHECK_STATUS(refl_image_convert_depth(d, refl_image_f32{d.data, d.len, w, h, stride}, &g,
                                        REFL_DEPTH_CONVENTION_LINEAR, REFL_DEPTH_CONVENTION_LINEAR, refl_row_range{0, h}),
                     REFL_STATUS_OK);
        CHECK_EQ(dst.data[0], 2.0f);
    }
}

// Seed 002 (reprojected ray casting): params, scratch size, reprojection,
// decisions per row range.
void epipolar_functions() {
    const refl_camera g = good_camera();  // 64 x 48
    const uint32_t w = g.width, h = g.height;
    const size_t n = size_t(w) * h;

    const refl_epipolar_options p = refl_epipolar_options_default();
    CHECK(p.m_cnt == 5 && p.splat_radius == 1 && p.resample_period == 9);

    const size_t sl = expect_ok<size_t>("epipolar_scratch_len",
                                        [&](size_t* o) { return refl_epipolar_scratch_len(o, w, h); });
    CHECK(sl >= 2 * size_t(w + h));
    const uint32_t bad_sizes[][2] = {{0, 1}, {1, 0}, {0, 0}};
    for (const auto& s : bad_sizes)
        expect<size_t>("epipolar_scratch_len bad", REFL_STATUS_INVALID_ARGUMENT,
                       [&](size_t* o) { return refl_epipolar_scratch_len(o, s[0], s[1]); });

    // POS: every pixel a point 5 units along its ray, object 0.
    std::vector<refl_epipolar_pos_entry> pos(n);
    for (uint32_t y = 0; y < h; ++y)
        for (uint32_t x = 0; x < w; ++x) {
            refl_ray r{};
            REQUIRE(refl_camera_primary_ray(&r, &g, v2(float(x) + 0.5f, float(y) + 0.5f)) == REFL_STATUS_OK);
            refl_epipolar_pos_entry& e = pos[size_t(y) * w + x];
            e.point[0] = r.origin.x + 5.0f * r.dir.x;
            e.point[1] = r.origin.y + 5.0f * r.dir.y;
            e.point[2] = r.origin.z + 5.0f * r.dir.z;
            e.object = 0;
            e.t = 5.0f;
        }
    refl_camera g2 = g;  // moved slightly forward
    g2.view.m[14] += 0.01f;
    const refl_epipolar_aip_entry sentinel{7u, 3.0f, 9u, 4.0f, 0u};
    struct AipCase {
        std::vector<refl_epipolar_aip_entry> aip;
        std::vector<float> scratch;
        refl_epipolar_stats stats;
        AipCase(size_t n, size_t sl, refl_epipolar_aip_entry s) : aip(n, s), scratch(sl, -1.0f), stats{} {
            stats.points = 77;
        }
    };
    auto reproject = [&](const char* what, refl_status want, auto call) {
        AipCase c(n + 1, sl + 1, sentinel);
        const uint32_t got = call(c);
        ++check::checks();
        bool untouched = c.stats.points == 77;
        for (const auto& a : c.aip)
            untouched = untouched && a.object == 7u && a.cnt == 9u && a.t == 3.0f && a.flags == 0u;
        if (got != static_cast<uint32_t>(want) || !untouched)
            check::fail(__FILE__, __LINE__,
                        std::string("epipolar_reproject ") + what + ": got " + check::status_name(got) +
                            ", expected " + check::status_name(want) + (untouched ? "" : ", and aip was written"));
    };
    auto rep = [&](size_t aip_len, size_t scratch_len, const refl_epipolar_pos_entry* pp, size_t pos_len,
                   const refl_camera* prev, const refl_camera* cur, const refl_epipolar_options* par) {
        return [=](AipCase& c) {
            return refl_epipolar_reproject(c.aip.data(), aip_len, c.scratch.data(), scratch_len, &c.stats, pp,
                                           pos_len, prev, cur, par);
        };
    };
    {
        AipCase c(n, sl, sentinel);
        CHECK_STATUS(refl_epipolar_reproject(c.aip.data(), n, c.scratch.data(), sl, &c.stats, pos.data(), n, &g,
                                             &g2, &p),
                     REFL_STATUS_OK);
        CHECK(c.stats.points == n && c.stats.splatted > 0);
    }
    reproject("NULL pos", REFL_STATUS_NULL_POINTER, rep(n, sl, nullptr, n, &g, &g2, &p));
    reproject("NULL previous", REFL_STATUS_NULL_POINTER, rep(n, sl, pos.data(), n, nullptr, &g2, &p));
    reproject("NULL current", REFL_STATUS_NULL_POINTER, rep(n, sl, pos.data(), n, &g, nullptr, &p));
    reproject("NULL params", REFL_STATUS_NULL_POINTER, rep(n, sl, pos.data(), n, &g, &g2, nullptr));
    reproject("NULL aip", REFL_STATUS_NULL_POINTER, [&](AipCase& c) {
        return refl_epipolar_reproject(nullptr, n, c.scratch.data(), sl, &c.stats, pos.data(), n, &g, &g2, &p);
    });
    reproject("NULL scratch", REFL_STATUS_NULL_POINTER, [&](AipCase& c) {
        return refl_epipolar_reproject(c.aip.data(), n, nullptr, sl, &c.stats, pos.data(), n, &g, &g2, &p);
    });
    reproject("NULL stats", REFL_STATUS_NULL_POINTER, [&](AipCase& c) {
        return refl_epipolar_reproject(c.aip.data(), n, c.scratch.data(), sl, nullptr, pos.data(), n, &g, &g2, &p);
    });
    reproject("short aip", REFL_STATUS_INSUFFICIENT_SIZE, rep(n - 1, sl, pos.data(), n, &g, &g2, &p));
    reproject("aip len 0", REFL_STATUS_INSUFFICIENT_SIZE, rep(0, sl, pos.data(), n, &g, &g2, &p));
    reproject("short scratch", REFL_STATUS_INSUFFICIENT_SIZE, rep(n, sl - 1, pos.data(), n, &g, &g2, &p));
    reproject("short pos", REFL_STATUS_INSUFFICIENT_SIZE, rep(n, sl, pos.data(), n - 1, &g, &g2, &p));
    reproject("aip len SIZE_MAX", REFL_STATUS_INVALID_ARGUMENT, rep(SIZE_MAX, sl, pos.data(), n, &g, &g2, &p));
    for (const BadCamera& b : bad_cameras()) {
        reproject(b.name, b.status, rep(n, sl, pos.data(), n, &b.cam, &g2, &p));
        reproject(b.name, b.status, rep(n, sl, pos.data(), n, &g, &b.cam, &p));
    }
    refl_camera other_size = g;
    other_size.width = w + 1;
    reproject("camera sizes differ", REFL_STATUS_INVALID_ARGUMENT,
              rep(n + 1, sl + 1, pos.data(), n, &g, &other_size, &p));
    std::vector<refl_epipolar_options> bad_params;
    auto bad_param = [&](auto edit) {
        refl_epipolar_options q = p;
        edit(q);
        bad_params.push_back(q);
    };
    bad_param([](refl_epipolar_options& q) { q.m_cnt = 0; });
    bad_param([](refl_epipolar_options& q) { q.splat_radius = REFL_EPIPOLAR_MAX_SPLAT_RADIUS + 1; });
    bad_param([](refl_epipolar_options& q) { q.splat_radius = kMax; });
    bad_param([](refl_epipolar_options& q) { q.shift_epsilon = kNaN; });
    bad_param([](refl_epipolar_options& q) { q.shift_epsilon = kInf; });
    bad_param([](refl_epipolar_options& q) { q.shift_epsilon = -1.0f; });
    bad_param([](refl_epipolar_options& q) { q.guard_margin = kNaN; });
    bad_param([](refl_epipolar_options& q) { q.guard_window = REFL_EPIPOLAR_MAX_SPLAT_RADIUS + 1; });
    bad_param([](refl_epipolar_options& q) { q.guard_margin = 1.0f; });
    bad_param([](refl_epipolar_options& q) { q.guard_margin = -0.5f; });
    for (const auto& q : bad_params)
        reproject("bad params", REFL_STATUS_INVALID_ARGUMENT, rep(n, sl, pos.data(), n, &g, &g2, &q));
    reproject("scratch overlaps aip", REFL_STATUS_INVALID_ARGUMENT, [&](AipCase& c) {
        return refl_epipolar_reproject(c.aip.data(), n, reinterpret_cast<float*>(c.aip.data()), sl, &c.stats,
                                       pos.data(), n, &g, &g2, &p);
    });
    reproject("misaligned scratch", REFL_STATUS_INVALID_ARGUMENT, [&](AipCase& c) {
        return refl_epipolar_reproject(
            c.aip.data(), n, reinterpret_cast<float*>(reinterpret_cast<unsigned char*>(c.scratch.data()) + 1),
            sl, &c.stats, pos.data(), n, &g, &g2, &p);
    });
    // NaN points are dropped (behind/outside), never undefined.
    {
        std::vector<refl_epipolar_pos_entry> nan_pos = pos;
        for (auto& e : nan_pos) e.point[0] = kNaN;
        AipCase c(n, sl, sentinel);
        CHECK_STATUS(refl_epipolar_reproject(c.aip.data(), n, c.scratch.data(), sl, &c.stats, nan_pos.data(), n,
                                             &g, &g2, &p),
                     REFL_STATUS_OK);
        CHECK(c.stats.splatted == 0);
    }

    // refl_epipolar_decide_rows
    std::vector<refl_epipolar_aip_entry> aip(n, refl_epipolar_aip_entry{REFL_EPIPOLAR_INVALID_OBJECT, kInf, 0u, kInf,
                                                                        REFL_EPIPOLAR_FLAG_NO_REPROJECTION});
    const refl_epipolar_decision dsent{12345u, -1.0f, -2.0f, 99u};
    auto decide = [&](const char* what, refl_status want, auto call) {
        std::vector<refl_epipolar_decision> out(n + 1, dsent);
        const uint32_t got = call(out.data());
        ++check::checks();
        bool untouched = true;
        for (const auto& d : out) untouched = untouched && d.object == 12345u && d.reason == 99u;
        if (got != static_cast<uint32_t>(want) || !untouched)
            check::fail(__FILE__, __LINE__,
                        std::string("epipolar_decide_rows ") + what + ": got " + check::status_name(got) +
                            ", expected " + check::status_name(want) + (untouched ? "" : ", and out was written"));
    };
    auto dec = [&](size_t out_len, const refl_epipolar_aip_entry* a, size_t aip_len, uint32_t width, uint32_t b,
                   uint32_t e, const refl_epipolar_options* par) {
        return [=](refl_epipolar_decision* o) {
            return refl_epipolar_decide_rows(o, out_len, a, aip_len, width, refl_row_range{b, e}, 0, par);
        };
    };
    {
        std::vector<refl_epipolar_decision> out(n, dsent);
        CHECK_STATUS(refl_epipolar_decide_rows(out.data(), n, aip.data(), n, w, refl_row_range{1, 3}, 0, &p), REFL_STATUS_OK);
        CHECK(out[0].reason == 99u && out[w].reason == REFL_EPIPOLAR_REASON_UNAVAILABLE &&
              out[3 * w].reason == 99u);
    }
    decide("NULL out", REFL_STATUS_NULL_POINTER,
           [&](refl_epipolar_decision*) { return dec(n, aip.data(), n, w, 0, h, &p)(nullptr); });
    decide("NULL aip", REFL_STATUS_NULL_POINTER, dec(n, nullptr, n, w, 0, h, &p));
    decide("NULL params", REFL_STATUS_NULL_POINTER, dec(n, aip.data(), n, w, 0, h, nullptr));
    decide("short out", REFL_STATUS_INSUFFICIENT_SIZE, dec(n - 1, aip.data(), n, w, 0, h, &p));
    decide("short aip", REFL_STATUS_INSUFFICIENT_SIZE, dec(n, aip.data(), n - 1, w, 0, h, &p));
    decide("rows beyond aip", REFL_STATUS_INSUFFICIENT_SIZE, dec(n, aip.data(), n, w, 0, h + 1, &p));
    decide("width 0", REFL_STATUS_INVALID_ARGUMENT, dec(n, aip.data(), n, 0, 0, h, &p));
    const uint32_t bad_rows[][2] = {{0, 0}, {3, 3}, {4, 2}, {kMax, kMax}};
    for (const auto& r : bad_rows)
        decide("rows", REFL_STATUS_INVALID_ARGUMENT, dec(n, aip.data(), n, w, r[0], r[1], &p));
    decide("width * rows overflow", sizeof(size_t) == 8 ? REFL_STATUS_INSUFFICIENT_SIZE : REFL_STATUS_INVALID_ARGUMENT,
           dec(n, aip.data(), n, kMax, 0, kMax, &p));
    for (const auto& q : bad_params) decide("bad params", REFL_STATUS_INVALID_ARGUMENT, dec(n, aip.data(), n, w, 0, h, &q));
    decide("out overlaps aip", REFL_STATUS_INVALID_ARGUMENT, [&](refl_epipolar_decision*) {
        return refl_epipolar_decide_rows(reinterpret_cast<refl_epipolar_decision*>(aip.data()), n, aip.data(), n, w,
                                         refl_row_range{0, h}, 0, &p);
    });
}

// Layered depth cube maps (seed 001): size query, column rays, filling,
// tracing, PRR classification.
void layered_functions() {
    const float ident[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    refl_layered_grid grid{};
    grid.min = v3(-1, -1, -1);
    grid.max = v3(1, 1, 1);
    grid.face_res = 4;
    grid.layers = 2;
    std::memcpy(grid.world_from_local.m, ident, sizeof ident);

    // refl_layered_len
    const refl_layered_sizes len =
        expect_ok<refl_layered_sizes>("layered_len", [](refl_layered_sizes* o) { return refl_layered_len(o, 4, 2); });
    CHECK_EQ(len.counts_len, size_t(6 * 16) + REFL_LAYERED_STAMP_LEN);
    CHECK_EQ(len.depth_len, size_t(6 * 16 * 2));
    expect<refl_layered_sizes>("layered_len res 0", REFL_STATUS_INVALID_ARGUMENT,
                             [](refl_layered_sizes* o) { return refl_layered_len(o, 0, 2); });
    expect<refl_layered_sizes>("layered_len layers 0", REFL_STATUS_INVALID_ARGUMENT,
                             [](refl_layered_sizes* o) { return refl_layered_len(o, 4, 0); });
    if (sizeof(size_t) == 8)
        expect<refl_layered_sizes>("layered_len overflow", REFL_STATUS_INVALID_ARGUMENT,
                                 [](refl_layered_sizes* o) { return refl_layered_len(o, kMax, kMax); });

    // refl_layered_options_default
    const refl_layered_options params = refl_layered_options_default();
    CHECK(params.step_texels > 0.0f && params.max_steps > 0);

    // refl_layered_face_ray
    const refl_layered_column_ray col = expect_ok<refl_layered_column_ray>(
        "face_ray", [&](refl_layered_column_ray* o) { return refl_layered_face_ray(o, &grid, 1, 0, 3); });
    CHECK_EQ(col.origin.x, -1.0f);
    CHECK_EQ(col.dir.x, 1.0f);
    CHECK_EQ(col.t_max, 2.0f);
    expect<refl_layered_column_ray>("face_ray face 6", REFL_STATUS_INVALID_ARGUMENT,
                            [&](refl_layered_column_ray* o) { return refl_layered_face_ray(o, &grid, 6, 0, 0); });
    expect<refl_layered_column_ray>("face_ray face max", REFL_STATUS_INVALID_ARGUMENT,
                            [&](refl_layered_column_ray* o) { return refl_layered_face_ray(o, &grid, kMax, 0, 0); });
    expect<refl_layered_column_ray>("face_ray texel", REFL_STATUS_INVALID_ARGUMENT,
                            [&](refl_layered_column_ray* o) { return refl_layered_face_ray(o, &grid, 0, 4, 0); });
    expect<refl_layered_column_ray>("face_ray NULL grid", REFL_STATUS_NULL_POINTER,
                            [&](refl_layered_column_ray* o) { return refl_layered_face_ray(o, nullptr, 0, 0, 0); }, false);
    const struct {
        const char* what;
        void (*edit)(refl_layered_grid&);
        refl_status st;
    } bad_grids[] = {
        {"min NaN", [](refl_layered_grid& g) { g.min.x = kNaN; }, REFL_STATUS_INVALID_ARGUMENT},
        {"max inf", [](refl_layered_grid& g) { g.max.z = kInf; }, REFL_STATUS_INVALID_ARGUMENT},
        {"flat box", [](refl_layered_grid& g) { g.max.y = g.min.y; }, REFL_STATUS_DEGENERATE_GEOMETRY},
        {"reversed box", [](refl_layered_grid& g) { g.max.x = -2.0f; }, REFL_STATUS_DEGENERATE_GEOMETRY},
        {"res 0", [](refl_layered_grid& g) { g.face_res = 0; }, REFL_STATUS_INVALID_ARGUMENT},
        {"layers 0", [](refl_layered_grid& g) { g.layers = 0; }, REFL_STATUS_INVALID_ARGUMENT},
        {"matrix NaN", [](refl_layered_grid& g) { g.world_from_local.m[5] = kNaN; }, REFL_STATUS_INVALID_ARGUMENT},
        {"matrix projective", [](refl_layered_grid& g) { g.world_from_local.m[3] = 0.5f; },
         REFL_STATUS_INVALID_ARGUMENT},
        {"matrix singular", [](refl_layered_grid& g) { g.world_from_local.m[0] = 0.0f; },
         REFL_STATUS_DEGENERATE_GEOMETRY},
    };
    for (const auto& b : bad_grids) {
        refl_layered_grid g = grid;
        b.edit(g);
        expect<refl_layered_column_ray>(b.what, b.st, [&](refl_layered_column_ray* o) { return refl_layered_face_ray(o, &g, 0, 0, 0); });
    }

    // The map buffers.
    std::vector<float> depth(len.depth_len, -7.0f), bounds(len.bounds_len, -7.0f);
    std::vector<uint32_t> payload(len.payload_len, 7u), counts(len.counts_len, 7u);
    const refl_layered_map_mut mm{grid,          depth.data(),  depth.size(),  payload.data(), payload.size(),
                                  counts.data(), counts.size(), bounds.data(), bounds.size()};
    auto map_untouched = [&]() {
        for (float d : depth)
            if (d != -7.0f) return false;
        for (float b : bounds)
            if (b != -7.0f) return false;
        for (uint32_t p : payload)
            if (p != 7u) return false;
        for (uint32_t c : counts)
            if (c != 7u) return false;
        return true;
    };

    // refl_layered_clear: only bad descriptors here (success is used below).
    CHECK_STATUS(refl_layered_clear(nullptr), REFL_STATUS_NULL_POINTER);
    {
        refl_layered_map_mut m = mm;
        m.depth = nullptr;
        CHECK_STATUS(refl_layered_clear(&m), REFL_STATUS_NULL_POINTER);
        m = mm;
        m.counts_len -= 1;
        CHECK_STATUS(refl_layered_clear(&m), REFL_STATUS_INSUFFICIENT_SIZE);
        m = mm;
        m.payload = counts.data();
        m.payload_len = counts.size();
        CHECK_STATUS(refl_layered_clear(&m), REFL_STATUS_INVALID_ARGUMENT);  // overlapping buffers
        m = mm;
        m.depth = reinterpret_cast<float*>(reinterpret_cast<unsigned char*>(depth.data()) + 1);
        m.depth_len -= 1;
        CHECK_STATUS(refl_layered_clear(&m), REFL_STATUS_INVALID_ARGUMENT);
        m = mm;
        m.grid.face_res = 0;
        CHECK_STATUS(refl_layered_clear(&m), REFL_STATUS_INVALID_ARGUMENT);
        m = mm;
        m.bounds = nullptr;
        CHECK_STATUS(refl_layered_clear(&m), REFL_STATUS_NULL_POINTER);
        m = mm;
        m.bounds_len -= 1;
        CHECK_STATUS(refl_layered_clear(&m), REFL_STATUS_INSUFFICIENT_SIZE);
        m = mm;
        m.bounds = depth.data();
        CHECK_STATUS(refl_layered_clear(&m), REFL_STATUS_INVALID_ARGUMENT);  // bounds overlap depth
        CHECK(map_untouched());
    }

    // refl_layered_build_bounds: bad descriptors leave everything untouched.
    CHECK_STATUS(refl_layered_build_bounds(nullptr), REFL_STATUS_NULL_POINTER);
    {
        refl_layered_map_mut m = mm;
        m.bounds = nullptr;
        CHECK_STATUS(refl_layered_build_bounds(&m), REFL_STATUS_NULL_POINTER);
        m = mm;
        m.bounds_len = 1;
        CHECK_STATUS(refl_layered_build_bounds(&m), REFL_STATUS_INSUFFICIENT_SIZE);
        m = mm;
        m.bounds = reinterpret_cast<float*>(reinterpret_cast<unsigned char*>(bounds.data()) + 1);
        m.bounds_len -= 1;
        CHECK_STATUS(refl_layered_build_bounds(&m), REFL_STATUS_INVALID_ARGUMENT);  // misaligned
        m = mm;
        m.grid.min.x = kNaN;
        CHECK_STATUS(refl_layered_build_bounds(&m), REFL_STATUS_INVALID_ARGUMENT);
        m = mm;
        m.grid.max.y = m.grid.min.y;
        CHECK_STATUS(refl_layered_build_bounds(&m), REFL_STATUS_DEGENERATE_GEOMETRY);
        CHECK(map_untouched());
    }

    // refl_layered_fill_column (the hits are the call's scratch: sorted in
    // place, so they are not const and must not overlap the map).
    refl_layered_layer_hit good_hits[2] = {{0.5f, 1u, true}, {1.5f, 2u, false}};
    refl_layered_layer_hit nan_hit[1] = {{kNaN, 1u, true}};
    refl_layered_layer_hit inf_hit[1] = {{kInf, 1u, false}};
    auto fill = [&](refl_layered_layer_hit* h, size_t n, uint32_t face, uint32_t i) {
        return [=, &mm](refl_layered_column_fill* o) { return refl_layered_fill_column(o, &mm, face, i, 0, h, n); };
    };
    expect<refl_layered_column_fill>("fill NaN t", REFL_STATUS_INVALID_ARGUMENT, fill(nan_hit, 1, 0, 0));
    expect<refl_layered_column_fill>("fill inf t", REFL_STATUS_INVALID_ARGUMENT, fill(inf_hit, 1, 0, 0));
    expect<refl_layered_column_fill>("fill hits aliasing the map", REFL_STATUS_INVALID_ARGUMENT,
                             fill(reinterpret_cast<refl_layered_layer_hit*>(mm.depth), 1, 0, 0));
    expect<refl_layered_column_fill>("fill face 6", REFL_STATUS_INVALID_ARGUMENT, fill(good_hits, 2, 6, 0));
    expect<refl_layered_column_fill>("fill texel 4", REFL_STATUS_INVALID_ARGUMENT, fill(good_hits, 2, 0, 4));
    expect<refl_layered_column_fill>("fill NULL hits", REFL_STATUS_NULL_POINTER, fill(nullptr, 2, 0, 0), false);
    expect<refl_layered_column_fill>("fill NULL map", REFL_STATUS_NULL_POINTER, [&](refl_layered_column_fill* o) {
        return refl_layered_fill_column(o, nullptr, 0, 0, 0, good_hits, 2);
    }, false);
    CHECK(map_untouched());

    // refl_layered_fill_face (the output count may be NULL).
    std::vector<size_t> offsets(17, 0);
    offsets[16] = 2;
    for (size_t k = 1; k < 16; ++k) offsets[k] = 2;
    auto face_fill = [&](const size_t* offs, size_t n_offs, refl_layered_layer_hit* h, size_t n) {
        return [=, &mm](uint32_t* o) { return refl_layered_fill_face(o, &mm, 1, h, n, offs, n_offs); };
    };
    expect<uint32_t>("fill_face short offsets", REFL_STATUS_INSUFFICIENT_SIZE,
                     face_fill(offsets.data(), 16, good_hits, 2), false);
    expect<uint32_t>("fill_face offsets beyond hits", REFL_STATUS_INVALID_ARGUMENT,
                     face_fill(offsets.data(), 17, good_hits, 1), false);
    std::vector<size_t> decreasing = offsets;
    decreasing[3] = 0;
    expect<uint32_t>("fill_face decreasing offsets", REFL_STATUS_INVALID_ARGUMENT,
                     face_fill(decreasing.data(), 17, good_hits, 2), false);
    expect<uint32_t>("fill_face NaN hit", REFL_STATUS_INVALID_ARGUMENT, face_fill(offsets.data(), 17, nan_hit, 1),
                     false);
    expect<uint32_t>("fill_face NULL offsets", REFL_STATUS_NULL_POINTER, face_fill(nullptr, 17, good_hits, 2), false);
    expect<uint32_t>("fill_face NULL map", REFL_STATUS_NULL_POINTER, [&](uint32_t* o) {
        return refl_layered_fill_face(o, nullptr, 1, good_hits, 2, offsets.data(), 17);
    }, false);
    CHECK(map_untouched());

    // A real map: a sphere-like column per texel of the -X face.
    // Every texel of the -X face gets the column [0.5, 1.5]: texel k's hits
    // are all_hits[2k .. 2k + 2).
    CHECK_STATUS(refl_layered_clear(&mm), REFL_STATUS_OK);
    std::vector<refl_layered_layer_hit> all_hits;
    std::vector<size_t> all_offsets(17, 0);
    for (size_t k = 0; k < 16; ++k) {
        all_hits.push_back(good_hits[0]);
        all_hits.push_back(good_hits[1]);
        all_offsets[k + 1] = all_hits.size();
    }
    uint32_t approximate = 7;
    CHECK_STATUS(
        refl_layered_fill_face(&approximate, &mm, 1, all_hits.data(), all_hits.size(), all_offsets.data(), 17),
        REFL_STATUS_OK);
    CHECK_EQ(approximate, 0u);  // one interval per column fits the layers
    const refl_layered_column_fill f = expect_ok<refl_layered_column_fill>(
        "fill_column", [&](refl_layered_column_fill* o) { return refl_layered_fill_column(o, &mm, 3, 1, 1, good_hits, 2); });
    CHECK(f.intervals == 1 && f.stored == 1);
    // Exact bounds again after the single-column fill: NaN-free.
    CHECK_STATUS(refl_layered_build_bounds(&mm), REFL_STATUS_OK);
    for (float b : bounds) CHECK(!std::isnan(b));

    // refl_layered_trace_ray
    const refl_layered_map map{grid,          depth.data(),  depth.size(),  payload.data(), payload.size(),
                               counts.data(), counts.size(), bounds.data(), bounds.size()};
    const refl_ray ray{v3(-3, 0.1f, 0.2f), v3(1, 0, 0)};
    const refl_layered_result r = expect_ok<refl_layered_result>(
        "trace", [&](refl_layered_result* o) { return refl_layered_trace_ray(o, &map, ray, kInf, &params); });
    CHECK(r.hit == 1);
    CHECK(std::fabs(r.t - 2.5f) < 0.6f);
    {
        // The map was cleared for `grid`: another resolution or box is
        // refused (was read with the wrong layout), and the message says so.
        refl_layered_map other = map;
        other.grid.layers = 1;
        expect<refl_layered_result>("trace map of another grid", REFL_STATUS_INVALID_ARGUMENT,
                                    [&](refl_layered_result* o) { return refl_layered_trace_ray(o, &other, ray, kInf, &params); });
        refl_layered_result rr{};
        CHECK_STATUS(refl_layered_trace_ray(&rr, &other, ray, kInf, &params), REFL_STATUS_INVALID_ARGUMENT);
        char msg[256];
        refl_last_error_message(msg, sizeof msg);
        CHECK(std::strstr(msg, "refl_layered_trace_ray: ") == msg && std::strstr(msg, "`map`") != nullptr);
        other = map;
        other.grid.max.x += 1.0f;
        expect<refl_layered_result>("trace map of another box", REFL_STATUS_INVALID_ARGUMENT,
                                    [&](refl_layered_result* o) { return refl_layered_trace_ray(o, &other, ray, kInf, &params); });
    }
    auto trace = [&](refl_ray rr, float t_max, const refl_layered_options* p) {
        return [=, &map](refl_layered_result* o) { return refl_layered_trace_ray(o, &map, rr, t_max, p); };
    };
    for (const refl_vec3& b : kBadVec3) {
        expect<refl_layered_result>("trace bad origin", REFL_STATUS_INVALID_ARGUMENT, trace({b, ray.dir}, kInf, &params));
        expect<refl_layered_result>("trace bad dir", REFL_STATUS_INVALID_ARGUMENT, trace({ray.origin, b}, kInf, &params));
    }
    expect<refl_layered_result>("trace dir not unit", REFL_STATUS_INVALID_ARGUMENT,
                                trace({ray.origin, v3(2, 0, 0)}, kInf, &params));
    for (float t : {kNaN, 0.0f, -1.0f, -kInf})
        expect<refl_layered_result>("trace t_max", REFL_STATUS_INVALID_ARGUMENT, trace(ray, t, &params));
    refl_layered_options bad_p = params;
    bad_p.step_texels = kNaN;
    expect<refl_layered_result>("trace step NaN", REFL_STATUS_INVALID_ARGUMENT, trace(ray, kInf, &bad_p));
    bad_p = params;
    bad_p.max_steps = 0;
    expect<refl_layered_result>("trace max_steps 0", REFL_STATUS_INVALID_ARGUMENT, trace(ray, kInf, &bad_p));
    bad_p = params;
    bad_p.binary_steps = kMax;
    expect<refl_layered_result>("trace binary_steps", REFL_STATUS_INVALID_ARGUMENT, trace(ray, kInf, &bad_p));
    for (float x : {kNaN, -1.0f, kInf}) {
        bad_p = params;
        bad_p.smooth_texels = x;
        expect<refl_layered_result>("trace smooth_texels", REFL_STATUS_INVALID_ARGUMENT, trace(ray, kInf, &bad_p));
    }
    expect<refl_layered_result>("trace NULL params", REFL_STATUS_NULL_POINTER, trace(ray, kInf, nullptr), false);
    expect<refl_layered_result>("trace NULL map", REFL_STATUS_NULL_POINTER, [&](refl_layered_result* o) {
        return refl_layered_trace_ray(o, nullptr, ray, kInf, &params);
    }, false);
    {
        refl_layered_map m = map;
        m.payload_len = 3;
        expect<refl_layered_result>("trace short payload", REFL_STATUS_INSUFFICIENT_SIZE, [&](refl_layered_result* o) {
            return refl_layered_trace_ray(o, &m, ray, kInf, &params);
        }, false);
        m = map;
        m.bounds_len = 3;
        expect<refl_layered_result>("trace short bounds", REFL_STATUS_INSUFFICIENT_SIZE, [&](refl_layered_result* o) {
            return refl_layered_trace_ray(o, &m, ray, kInf, &params);
        }, false);
        m = map;
        m.bounds = nullptr;
        expect<refl_layered_result>("trace NULL bounds", REFL_STATUS_NULL_POINTER, [&](refl_layered_result* o) {
            return refl_layered_trace_ray(o, &m, ray, kInf, &params);
        }, false);
    }

    // refl_layered_trace_rays
    const refl_ray rays[3] = {ray, {v3(-3, 5, 0), v3(1, 0, 0)}, {v3(0, 0, 0), v3(0, 1, 0)}};
    const refl_ray bad_rays[2] = {ray, {v3(kNaN, 0, 0), v3(1, 0, 0)}};
    {
        std::vector<refl_layered_result> out(3);
        CHECK_STATUS(refl_layered_trace_rays(out.data(), 3, &map, rays, 3, kInf, &params), REFL_STATUS_OK);
        CHECK(out[0].hit == 1 && out[1].hit == 0 && out[1].miss == REFL_LAYERED_MISS_MISSED_BOX);
        CHECK_STATUS(refl_layered_trace_rays(nullptr, 0, &map, nullptr, 0, kInf, &params), REFL_STATUS_OK);
    }
    auto batch = [&](const refl_ray* rr, size_t n, size_t out_len) {
        return [=, &map](refl_layered_result* o) {
            return refl_layered_trace_rays(o, out_len, &map, rr, n, kInf, &params);
        };
    };
    expect<refl_layered_result>("trace_rays bad ray", REFL_STATUS_INVALID_ARGUMENT, batch(bad_rays, 2, 2), false);
    expect<refl_layered_result>("trace_rays NULL rays", REFL_STATUS_NULL_POINTER, batch(nullptr, 1, 1), false);
    expect<refl_layered_result>("trace_rays short out", REFL_STATUS_INSUFFICIENT_SIZE, batch(rays, 2, 1), false);
    CHECK_STATUS(refl_layered_trace_rays(nullptr, 1, &map, rays, 1, kInf, &params), REFL_STATUS_NULL_POINTER);
    CHECK_STATUS(refl_layered_trace_rays(nullptr, 1, nullptr, rays, 1, kInf, &params), REFL_STATUS_NULL_POINTER);

    // refl_layered_prr_classify
    const refl_vec3 t0 = v3(-10, 0, -10), t1 = v3(10, 0, -10), t2 = v3(0, 0, 10);
    const uint32_t cls = expect_ok<uint32_t>("prr_classify", [&](uint32_t* o) {
        return refl_layered_prr_classify(o, v3(0, 3, 5), v3(0, 1, 0), 0.3f, t0, t1, t2);
    });
    CHECK_EQ(cls, uint32_t(REFL_LAYERED_PRR_CLASS_ELLIPSE));
    for (const refl_vec3& b : kBadVec3) {
        expect<uint32_t>("prr bad eye", REFL_STATUS_INVALID_ARGUMENT,
                         [&](uint32_t* o) { return refl_layered_prr_classify(o, b, v3(0, 1, 0), 0.3f, t0, t1, t2); });
        expect<uint32_t>("prr bad vertex", REFL_STATUS_INVALID_ARGUMENT,
                         [&](uint32_t* o) { return refl_layered_prr_classify(o, v3(0, 3, 5), v3(0, 1, 0), 0.3f, t0, b, t2); });
    }
    for (float r : {kNaN, 0.0f, -1.0f, kInf})
        expect<uint32_t>("prr radius", REFL_STATUS_INVALID_ARGUMENT,
                         [&](uint32_t* o) { return refl_layered_prr_classify(o, v3(0, 3, 5), v3(0, 1, 0), r, t0, t1, t2); });
    expect<uint32_t>("prr degenerate", REFL_STATUS_DEGENERATE_GEOMETRY,
                     [&](uint32_t* o) { return refl_layered_prr_classify(o, v3(0, 3, 5), v3(0, 1, 0), 0.3f, t0, t0, t2); });
}

// Per-pixel stepping: refl_step_ray (one ray) and refl_step_rays (a batch).
void refine_functions() {
    const refl_camera g = good_camera();
    const uint32_t w = g.width, h = g.height;
    const size_t n = size_t(w) * h;
    std::vector<float> depth(n, 0.5f);
    const refl_depth_image img{{depth.data(), n, w, h, w}, g, REFL_DEPTH_CONVENTION_ZERO_TO_ONE};
    const refl_image_f32 none{nullptr, 0, 0, 0, 0};
    const refl_trace_thickness th{0.5f, none};
    const refl_step_options defaults = refl_step_options_default();
    CHECK(defaults.stride == 1 && defaults.max_steps == UINT32_MAX);
    const refl_step_options opts{1, 1000};
    const float dx = -1.0f, dy = -1.5f, dz = -5.0f;
    const float inv = 1.0f / std::sqrt(dx * dx + dy * dy + dz * dz);
    const refl_ray ray{v3(1, 2, 5), v3(dx * inv, dy * inv, dz * inv)};
    const refl_trace_result hit = expect_ok<refl_trace_result>(
        "refine: step_ray", [&](refl_trace_result* o) { return refl_step_ray(o, &img, &th, ray, kInf, &opts); });
    CHECK_EQ(hit.miss, uint32_t(REFL_TRACE_MISS_NONE));
    // A flat depth image: the refined hit stays on the ray, in the image.
    const refl_trace_result r = expect_ok<refl_trace_result>(
        "refine_hit", [&](refl_trace_result* o) { return refl_trace_refine_hit(o, &img, ray, kInf, &hit); });
    CHECK_EQ(r.miss, uint32_t(REFL_TRACE_MISS_NONE));
    CHECK(r.pixel.x >= 0.0f && r.pixel.x < float(w) && r.pixel.y >= 0.0f && r.pixel.y < float(h));
    CHECK(r.fetches >= hit.fetches);
    // A miss passes through unchanged.
    refl_trace_result miss = hit;
    miss.miss = REFL_TRACE_MISS_LEFT_IMAGE;
    const refl_trace_result m = expect_ok<refl_trace_result>(
        "refine miss", [&](refl_trace_result* o) { return refl_trace_refine_hit(o, &img, ray, kInf, &miss); });
    CHECK(std::memcmp(&m, &miss, sizeof m) == 0);
    auto one = [&](const char* what, refl_status want, const refl_depth_image* i, refl_ray rr, float t_max,
                   const refl_trace_result* in) {
        expect<refl_trace_result>(what, want,
                                  [=](refl_trace_result* o) { return refl_trace_refine_hit(o, i, rr, t_max, in); });
    };
    one("refine NULL image", REFL_STATUS_NULL_POINTER, nullptr, ray, kInf, &hit);
    one("refine NULL hit", REFL_STATUS_NULL_POINTER, &img, ray, kInf, nullptr);
    refl_depth_image bad = img;
    bad.depth.data = nullptr;
    one("refine NULL depth data", REFL_STATUS_NULL_POINTER, &bad, ray, kInf, &hit);
    for (uint32_t c : kBadConventions) {
        bad = img;
        bad.convention = c;
        one("refine convention", REFL_STATUS_INVALID_ARGUMENT, &bad, ray, kInf, &hit);
    }
    for (const BadCamera& b : bad_cameras()) {
        bad = img;
        bad.camera = b.cam;
        one(b.name, b.status, &bad, ray, kInf, &hit);
    }
    bad = img;
    bad.depth.len = n - 1;
    one("refine depth short", REFL_STATUS_INSUFFICIENT_SIZE, &bad, ray, kInf, &hit);
    for (const refl_vec3& v : kBadVec3) {
        one("refine origin", REFL_STATUS_INVALID_ARGUMENT, &img, refl_ray{v, ray.dir}, kInf, &hit);
        one("refine dir", REFL_STATUS_INVALID_ARGUMENT, &img, refl_ray{ray.origin, v}, kInf, &hit);
    }
    for (float t : {kNaN, 0.0f, -1.0f, -kInf}) one("refine t_max", REFL_STATUS_INVALID_ARGUMENT, &img, ray, t, &hit);
    for (uint32_t bad_miss : {6u, 1000u, kMax}) {
        refl_trace_result b = hit;
        b.miss = bad_miss;
        one("refine miss value", REFL_STATUS_INVALID_ARGUMENT, &img, ray, kInf, &b);
    }
    for (float f : {kNaN, kInf, -kInf}) {
        refl_trace_result b = hit;
        b.t = f;
        one("refine hit t", REFL_STATUS_INVALID_ARGUMENT, &img, ray, kInf, &b);
        b = hit;
        b.pixel.x = f;
        one("refine hit pixel", REFL_STATUS_INVALID_ARGUMENT, &img, ray, kInf, &b);
    }
}

void step_functions() {
    const refl_camera g = good_camera();
    const uint32_t w = g.width, h = g.height;
    const size_t n = size_t(w) * h;
    std::vector<float> depth(n, 0.5f), back(n, 0.6f);
    const refl_image_f32 none{nullptr, 0, 0, 0, 0};
    const refl_depth_image img{{depth.data(), n, w, h, w}, g, REFL_DEPTH_CONVENTION_ZERO_TO_ONE};
    const refl_trace_thickness th{0.5f, none};
    const refl_trace_thickness thb{0.0f, {back.data(), n, w, h, w}};
    const refl_step_options opts{1, 1000};
    // From the eye toward the camera's target: the planar case.
    const float dx = -1.0f, dy = -1.5f, dz = -5.0f;
    const float inv = 1.0f / std::sqrt(dx * dx + dy * dy + dz * dz);
    const refl_ray ray{v3(1, 2, 5), v3(dx * inv, dy * inv, dz * inv)};

    for (const refl_trace_thickness* t : {&th, &thb}) {
        const refl_trace_result r = expect_ok<refl_trace_result>(
            "step_ray", [&](refl_trace_result* o) { return refl_step_ray(o, &img, t, ray, kInf, &opts); });
        CHECK_EQ(r.miss, uint32_t(REFL_TRACE_MISS_NONE));
        CHECK(r.steps >= 1 && r.steps <= 2);
    }
    auto one = [&](const char* what, refl_status want, const refl_depth_image* i, const refl_trace_thickness* t,
                   refl_ray r, float t_max, const refl_step_options* o) {
        expect<refl_trace_result>(what, want,
                                  [=](refl_trace_result* out) { return refl_step_ray(out, i, t, r, t_max, o); });
    };
    one("step NULL image", REFL_STATUS_NULL_POINTER, nullptr, &th, ray, kInf, &opts);
    one("step NULL thickness", REFL_STATUS_NULL_POINTER, &img, nullptr, ray, kInf, &opts);
    one("step NULL options", REFL_STATUS_NULL_POINTER, &img, &th, ray, kInf, nullptr);
    refl_depth_image bad = img;
    bad.depth.data = nullptr;
    one("step NULL depth data", REFL_STATUS_NULL_POINTER, &bad, &th, ray, kInf, &opts);
    for (uint32_t c : kBadConventions) {
        bad = img;
        bad.convention = c;
        one("step convention", REFL_STATUS_INVALID_ARGUMENT, &bad, &th, ray, kInf, &opts);
    }
    for (const BadCamera& b : bad_cameras()) {
        bad = img;
        bad.camera = b.cam;
        one(b.name, b.status, &bad, &th, ray, kInf, &opts);
    }
    bad = img;
    bad.depth.len = n - 1;
    one("step depth short", REFL_STATUS_INSUFFICIENT_SIZE, &bad, &th, ray, kInf, &opts);
    bad = img;
    bad.depth.height = h - 1;
    one("step depth size != camera", REFL_STATUS_INVALID_ARGUMENT, &bad, &th, ray, kInf, &opts);
    bad = img;
    bad.depth.width = bad.depth.height = bad.depth.stride = kMax;
    bad.depth.len = SIZE_MAX;
    one("step depth overflowing", REFL_STATUS_INVALID_ARGUMENT, &bad, &th, ray, kInf, &opts);
    bad = img;
    bad.depth.data = reinterpret_cast<const float*>(reinterpret_cast<const unsigned char*>(depth.data()) + 1);
    bad.depth.len = n - 1;
    one("step depth misaligned", REFL_STATUS_INVALID_ARGUMENT, &bad, &th, ray, kInf, &opts);
    for (const refl_vec3& v : kBadVec3) {
        one("step origin", REFL_STATUS_INVALID_ARGUMENT, &img, &th, refl_ray{v, ray.dir}, kInf, &opts);
        one("step dir", REFL_STATUS_INVALID_ARGUMENT, &img, &th, refl_ray{ray.origin, v}, kInf, &opts);
    }
    one("step dir not unit", REFL_STATUS_INVALID_ARGUMENT, &img, &th, refl_ray{ray.origin, v3(0, 0, -2)}, kInf,
        &opts);
    one("step dir zero", REFL_STATUS_INVALID_ARGUMENT, &img, &th, refl_ray{ray.origin, v3(0, 0, 0)}, kInf, &opts);
    for (float t : {kNaN, 0.0f, -1.0f, -kInf})
        one("step t_max", REFL_STATUS_INVALID_ARGUMENT, &img, &th, ray, t, &opts);
    const refl_step_options zero_stride{0, 1000};
    one("step stride 0", REFL_STATUS_INVALID_ARGUMENT, &img, &th, ray, kInf, &zero_stride);
    for (float c : {kNaN, -1.0f, -kInf}) {
        const refl_trace_thickness t{c, none};
        one("step thickness", REFL_STATUS_INVALID_ARGUMENT, &img, &t, ray, kInf, &opts);
    }
    refl_trace_thickness tb = thb;
    tb.back_faces.width = w - 1;
    one("step back faces size", REFL_STATUS_INVALID_ARGUMENT, &img, &tb, ray, kInf, &opts);
    tb = thb;
    tb.back_faces.len = 3;
    one("step back faces short", REFL_STATUS_INSUFFICIENT_SIZE, &img, &tb, ray, kInf, &opts);

    // refl_step_rays: the whole output array stays untouched on error.
    const size_t count = 5;
    std::vector<refl_ray> rays(count, ray);
    rays[1].origin = v3(0.5f, 1.0f, 2.0f);
    std::vector<float> t_max(count, 50.0f);
    auto batch = [&](const char* what, refl_status want, size_t out_len, const refl_ray* r, size_t rc,
                     const float* t, size_t tc, const refl_depth_image* i, const refl_trace_thickness* tk,
                     const refl_step_options* o, bool null_out = false) {
        std::vector<refl_trace_result> out(count + 1);
        std::memset(static_cast<void*>(out.data()), 0xA5, out.size() * sizeof(refl_trace_result));
        std::vector<unsigned char> before(out.size() * sizeof(refl_trace_result));
        std::memcpy(before.data(), out.data(), before.size());
        const uint32_t got = refl_step_rays(null_out ? nullptr : out.data(), out_len, i, tk, r, rc, t, tc, o);
        ++check::checks();
        const bool same = std::memcmp(before.data(), out.data(), before.size()) == 0;
        if (got != static_cast<uint32_t>(want) || (want != REFL_STATUS_OK && !same) ||
            (want == REFL_STATUS_OK && same))
            check::fail(__FILE__, __LINE__,
                        std::string("step_rays ") + what + ": got " + check::status_name(got) + ", expected " +
                            check::status_name(want));
        if (want == REFL_STATUS_OK) CHECK(std::memcmp(before.data() + count * sizeof(refl_trace_result),
                                                      reinterpret_cast<unsigned char*>(out.data()) +
                                                          count * sizeof(refl_trace_result),
                                                      sizeof(refl_trace_result)) == 0);
    };
    batch("ok", REFL_STATUS_OK, count, rays.data(), count, t_max.data(), count, &img, &th, &opts);
    batch("ok one t_max", REFL_STATUS_OK, count, rays.data(), count, t_max.data(), 1, &img, &thb, &opts);
    batch("NULL out", REFL_STATUS_NULL_POINTER, count, rays.data(), count, t_max.data(), count, &img, &th, &opts,
          true);
    batch("NULL rays", REFL_STATUS_NULL_POINTER, count, nullptr, count, t_max.data(), count, &img, &th, &opts);
    batch("NULL t_max", REFL_STATUS_NULL_POINTER, count, rays.data(), count, nullptr, count, &img, &th, &opts);
    batch("NULL image", REFL_STATUS_NULL_POINTER, count, rays.data(), count, t_max.data(), count, nullptr, &th,
          &opts);
    batch("NULL thickness", REFL_STATUS_NULL_POINTER, count, rays.data(), count, t_max.data(), count, &img,
          nullptr, &opts);
    batch("NULL options", REFL_STATUS_NULL_POINTER, count, rays.data(), count, t_max.data(), count, &img, &th,
          nullptr);
    batch("out short", REFL_STATUS_INSUFFICIENT_SIZE, count - 1, rays.data(), count, t_max.data(), count, &img,
          &th, &opts);
    batch("t_max short", REFL_STATUS_INSUFFICIENT_SIZE, count, rays.data(), count, t_max.data(), 2, &img, &th,
          &opts);
    batch("t_max count 0", REFL_STATUS_INVALID_ARGUMENT, count, rays.data(), count, t_max.data(), 0, &img, &th,
          &opts);
    {
        // The output array is written in place: it must not overlap an input.
        std::vector<refl_trace_result> out(count);
        std::memset(static_cast<void*>(out.data()), 0xA5, out.size() * sizeof(refl_trace_result));
        const auto* aliased = reinterpret_cast<const refl_ray*>(out.data());
        CHECK_STATUS(refl_step_rays(out.data(), count, &img, &th, aliased, count, t_max.data(), count, &opts),
                     REFL_STATUS_INVALID_ARGUMENT);
        CHECK_STATUS(refl_step_rays(out.data(), count, &img, &th, rays.data(), count,
                                    reinterpret_cast<const float*>(out.data()), count, &opts),
                     REFL_STATUS_INVALID_ARGUMENT);
    }
    bad = img;
    bad.convention = 9;
    batch("convention", REFL_STATUS_INVALID_ARGUMENT, count, rays.data(), count, t_max.data(), count, &bad, &th,
          &opts);
    batch("stride 0", REFL_STATUS_INVALID_ARGUMENT, count, rays.data(), count, t_max.data(), count, &img, &th,
          &zero_stride);
    for (const refl_vec3& v : kBadVec3) {
        std::vector<refl_ray> r = rays;
        r[count - 1].dir = v;
        batch("NaN ray", REFL_STATUS_INVALID_ARGUMENT, count, r.data(), count, t_max.data(), count, &img, &th,
              &opts);
    }
    std::vector<float> bad_t = t_max;
    bad_t[2] = kNaN;
    batch("NaN t_max", REFL_STATUS_INVALID_ARGUMENT, count, rays.data(), count, bad_t.data(), count, &img, &th,
          &opts);
    batch("huge count", REFL_STATUS_INVALID_ARGUMENT, SIZE_MAX, rays.data(), SIZE_MAX / 2, t_max.data(), 1, &img,
          &th, &opts);
}

// Hi-Z pyramid and traversal (seed 004): size and layout queries, whole and
// row-band builds into the caller buffer, one ray and a batch.
void hiz_functions() {
    const refl_camera g = good_camera();
    const uint32_t w = g.width, h = g.height;
    const size_t n = size_t(w) * h;
    std::vector<float> depth(n, 0.5f), back(n, 0.6f);
    const refl_image_f32 none{nullptr, 0, 0, 0, 0};
    const refl_depth_image img{{depth.data(), n, w, h, w}, g, REFL_DEPTH_CONVENTION_ZERO_TO_ONE};

    // The lane query: NULL refused; otherwise 1 (scalar) or 8 (AVX2).
    CHECK_STATUS(refl_hiz_stream_lanes(nullptr), REFL_STATUS_NULL_POINTER);
    {
        uint32_t lanes = 0;
        CHECK_STATUS(refl_hiz_stream_lanes(&lanes), REFL_STATUS_OK);
        CHECK(lanes == 1 || lanes == 8);
    }

    // Size and layout queries.
    size_t len = 0;
    uint32_t levels = 0;
    CHECK_STATUS(refl_hiz_len(&len, &levels, w, h), REFL_STATUS_OK);
    CHECK(len > n && levels == 7);
    for (uint32_t bw : {0u, w}) {
        const uint32_t bh = bw == 0 ? h : 0;
        expect<size_t>("hiz_len zero size", REFL_STATUS_INVALID_ARGUMENT, [=](size_t* o) {
            uint32_t c = 0;
            return refl_hiz_len(o, &c, bw, bh);
        });
        expect<uint32_t>("hiz_len levels zero size", REFL_STATUS_INVALID_ARGUMENT, [=](uint32_t* o) {
            size_t l = 0;
            return refl_hiz_len(&l, o, bw, bh);
        });
    }
    expect<size_t>("hiz_len overflowing", REFL_STATUS_INVALID_ARGUMENT, [](size_t* o) {
        uint32_t c = 0;
        return refl_hiz_len(o, &c, kMax, kMax);
    });
    const refl_hiz_level_info l0 = expect_ok<refl_hiz_level_info>(
        "hiz_level 0", [&](refl_hiz_level_info* o) { return refl_hiz_level(o, w, h, 0); });
    CHECK(l0.offset == 0 && l0.width == w && l0.height == h);
    const refl_hiz_level_info top = expect_ok<refl_hiz_level_info>(
        "hiz_level top", [&](refl_hiz_level_info* o) { return refl_hiz_level(o, w, h, levels - 1); });
    CHECK(top.width == 1 && top.height == 1 && top.offset == len - 1 - REFL_HIZ_STAMP_TEXELS);
    for (uint32_t lv : {levels, levels + 1, kMax})
        expect<refl_hiz_level_info>("hiz_level past last", REFL_STATUS_INVALID_ARGUMENT,
                                    [=](refl_hiz_level_info* o) { return refl_hiz_level(o, w, h, lv); });
    expect<refl_hiz_level_info>("hiz_level zero size", REFL_STATUS_INVALID_ARGUMENT,
                                [=](refl_hiz_level_info* o) { return refl_hiz_level(o, 0, h, 0); });
    const refl_hiz_options opts = refl_hiz_options_default();
    CHECK(opts.start_level == 2 && opts.stop_level == 0 && opts.max_iterations == 1024 && opts.prologue_steps == 4);

    // Builds: on error the whole destination stays byte-identical.
    std::vector<refl_vec2> pyr(len);
    CHECK_STATUS(refl_hiz_build(pyr.data(), len, &img), REFL_STATUS_OK);
    CHECK(pyr[0].x == pyr[0].y && pyr[0].x > 0.0f && pyr[top.offset].x == pyr[0].x);
    {
        // The pyramid records the camera it was built for: another size or
        // pose is refused (was OK with every ray missing), and the
        // last-error message says what it was built for.
        refl_camera other = g;
        other.width = w / 2;
        other.height = h / 2;
        const refl_hiz wrong{pyr.data(), len, other, REFL_DEPTH_CONVENTION_ZERO_TO_ONE};
        refl_trace_result r{};
        const refl_trace_thickness t1{1.0f, none};
        CHECK_STATUS(refl_hiz_trace_ray(&r, &wrong, &t1, refl_ray{v3(0, 0, 0), v3(0, 0, -1)}, kInf, &opts),
                     REFL_STATUS_INVALID_ARGUMENT);
        char msg[256];
        const size_t mlen = refl_last_error_message(msg, sizeof msg);
        CHECK(mlen > 0 && mlen < sizeof msg);
        CHECK(std::strstr(msg, "refl_hiz_trace_ray: ") == msg);
        CHECK(std::strstr(msg, "the camera is") != nullptr);
        other = g;
        other.view.m[12] += 0.25f;
        const refl_hiz moved{pyr.data(), len, other, REFL_DEPTH_CONVENTION_ZERO_TO_ONE};
        CHECK_STATUS(refl_hiz_trace_ray(&r, &moved, &t1, refl_ray{v3(0, 0, 0), v3(0, 0, -1)}, kInf, &opts),
                     REFL_STATUS_INVALID_ARGUMENT);
        // A truncated copy is NUL-terminated and the length is the whole one.
        char tiny[8];
        CHECK(refl_last_error_message(tiny, sizeof tiny) > sizeof tiny && tiny[7] == '\0');
    }
    auto build = [&](const char* what, refl_status want, size_t dl, const refl_depth_image* i, int mode,
                     uint32_t level = kMax, uint32_t r0 = 0, uint32_t r1 = 0) {
        std::vector<unsigned char> buf((len + 2) * sizeof(refl_vec2) + 16);
        for (size_t k = 0; k < buf.size(); ++k) buf[k] = pattern(k);
        const std::vector<unsigned char> before = buf;
        unsigned char* base = buf.data() + (16 - reinterpret_cast<uintptr_t>(buf.data()) % 16);
        refl_vec2* dst = mode == 1 ? nullptr : reinterpret_cast<refl_vec2*>(base + (mode == 2 ? 1 : 0));
        const uint32_t got =
            level == kMax ? refl_hiz_build(dst, dl, i) : refl_hiz_build_rows(dst, dl, i, level, refl_row_range{r0, r1});
        ++check::checks();
        if (got != static_cast<uint32_t>(want) || buf != before)
            check::fail(__FILE__, __LINE__,
                        std::string("hiz build ") + what + ": got " + check::status_name(got) + ", expected " +
                            check::status_name(want));
    };
    for (uint32_t lv : {kMax, 0u}) {
        const uint32_t r1 = lv == kMax ? 0 : h;
        build("NULL dst", REFL_STATUS_NULL_POINTER, len, &img, 1, lv, 0, r1);
        build("NULL image", REFL_STATUS_NULL_POINTER, len, nullptr, 0, lv, 0, r1);
        build("dst short", REFL_STATUS_INSUFFICIENT_SIZE, len - 1, &img, 0, lv, 0, r1);
        build("dst misaligned", REFL_STATUS_INVALID_ARGUMENT, len, &img, 2, lv, 0, r1);
        build("dst huge", REFL_STATUS_INVALID_ARGUMENT, SIZE_MAX, &img, 0, lv, 0, r1);
        refl_depth_image bad = img;
        bad.depth.data = nullptr;
        build("NULL depth data", REFL_STATUS_NULL_POINTER, len, &bad, 0, lv, 0, r1);
        for (uint32_t c : kBadConventions) {
            bad = img;
            bad.convention = c;
            build("convention", REFL_STATUS_INVALID_ARGUMENT, len, &bad, 0, lv, 0, r1);
        }
        for (const BadCamera& b : bad_cameras()) {
            bad = img;
            bad.camera = b.cam;
            build(b.name, b.status, len, &bad, 0, lv, 0, r1);
        }
        bad = img;
        bad.depth.len = n - 1;
        build("depth short", REFL_STATUS_INSUFFICIENT_SIZE, len, &bad, 0, lv, 0, r1);
        bad = img;
        bad.depth.width = w - 1;
        build("depth size != camera", REFL_STATUS_INVALID_ARGUMENT, len, &bad, 0, lv, 0, r1);
    }
    build("rows level past last", REFL_STATUS_INVALID_ARGUMENT, len, &img, 0, levels, 0, 1);
    build("rows empty", REFL_STATUS_INVALID_ARGUMENT, len, &img, 0, 0, 3, 3);
    build("rows reversed", REFL_STATUS_INVALID_ARGUMENT, len, &img, 0, 0, 4, 2);
    build("rows past height", REFL_STATUS_INVALID_ARGUMENT, len, &img, 0, 1, 0, h);
    {
        // The pyramid may not overlap the depth image it reads.
        std::vector<float> shared(n + 2 * len + 4, 0.5f);
        const refl_depth_image si{{shared.data(), n, w, h, w}, g, REFL_DEPTH_CONVENTION_ZERO_TO_ONE};
        const std::vector<float> before = shared;
        CHECK_STATUS(refl_hiz_build(reinterpret_cast<refl_vec2*>(shared.data() + 2), len, &si),
                     REFL_STATUS_INVALID_ARGUMENT);
        CHECK(std::memcmp(before.data(), shared.data(), shared.size() * sizeof(float)) == 0);
    }
    {
        // Level by level, row band by row band: equal to the whole build.
        std::vector<refl_vec2> banded(len);
        for (uint32_t lv = 0; lv < levels; ++lv) {
            refl_hiz_level_info li{};
            CHECK_STATUS(refl_hiz_level(&li, w, h, lv), REFL_STATUS_OK);
            for (uint32_t r = 0; r < li.height; r += 2)
                CHECK_STATUS(refl_hiz_build_rows(banded.data(), len, &img, lv, refl_row_range{r, r + 2 < li.height ? r + 2 : li.height}),
                             REFL_STATUS_OK);
        }
        CHECK(std::memcmp(banded.data(), pyr.data(), len * sizeof(refl_vec2)) == 0);
    }

    // One ray.
    const refl_hiz hz{pyr.data(), len, g, REFL_DEPTH_CONVENTION_ZERO_TO_ONE};
    const refl_trace_thickness th{0.5f, none};
    const refl_trace_thickness thb{0.0f, {back.data(), n, w, h, w}};
    const float dx = -1.0f, dy = -1.5f, dz = -5.0f;
    const float inv = 1.0f / std::sqrt(dx * dx + dy * dy + dz * dz);
    const refl_ray ray{v3(1, 2, 5), v3(dx * inv, dy * inv, dz * inv)};
    for (const refl_trace_thickness* t : {&th, &thb}) {
        const refl_trace_result r = expect_ok<refl_trace_result>(
            "hiz_trace_ray", [&](refl_trace_result* o) { return refl_hiz_trace_ray(o, &hz, t, ray, kInf, &opts); });
        CHECK_EQ(r.miss, uint32_t(REFL_TRACE_MISS_NONE));
        CHECK(r.fetches >= 1);
    }
    auto one = [&](const char* what, refl_status want, const refl_hiz* z, const refl_trace_thickness* t, refl_ray r,
                   float t_max, const refl_hiz_options* o) {
        expect<refl_trace_result>(
            what, want, [=](refl_trace_result* out) { return refl_hiz_trace_ray(out, z, t, r, t_max, o); });
    };
    one("hiz NULL pyramid", REFL_STATUS_NULL_POINTER, nullptr, &th, ray, kInf, &opts);
    one("hiz NULL thickness", REFL_STATUS_NULL_POINTER, &hz, nullptr, ray, kInf, &opts);
    one("hiz NULL options", REFL_STATUS_NULL_POINTER, &hz, &th, ray, kInf, nullptr);
    refl_hiz bad = hz;
    bad.data = nullptr;
    one("hiz NULL data", REFL_STATUS_NULL_POINTER, &bad, &th, ray, kInf, &opts);
    bad = hz;
    bad.len = len - 1;
    one("hiz pyramid short", REFL_STATUS_INSUFFICIENT_SIZE, &bad, &th, ray, kInf, &opts);
    bad = hz;
    bad.data = reinterpret_cast<const refl_vec2*>(reinterpret_cast<const unsigned char*>(pyr.data()) + 1);
    bad.len = len - 1;
    one("hiz pyramid misaligned", REFL_STATUS_INVALID_ARGUMENT, &bad, &th, ray, kInf, &opts);
    bad = hz;
    bad.len = SIZE_MAX;
    one("hiz pyramid huge", REFL_STATUS_INVALID_ARGUMENT, &bad, &th, ray, kInf, &opts);
    for (uint32_t c : kBadConventions) {
        bad = hz;
        bad.convention = c;
        one("hiz convention", REFL_STATUS_INVALID_ARGUMENT, &bad, &th, ray, kInf, &opts);
    }
    for (const BadCamera& b : bad_cameras()) {
        bad = hz;
        bad.camera = b.cam;
        one(b.name, b.status, &bad, &th, ray, kInf, &opts);
    }
    for (const refl_vec3& v : kBadVec3) {
        one("hiz origin", REFL_STATUS_INVALID_ARGUMENT, &hz, &th, refl_ray{v, ray.dir}, kInf, &opts);
        one("hiz dir", REFL_STATUS_INVALID_ARGUMENT, &hz, &th, refl_ray{ray.origin, v}, kInf, &opts);
    }
    one("hiz dir not unit", REFL_STATUS_INVALID_ARGUMENT, &hz, &th, refl_ray{ray.origin, v3(0, 0, -2)}, kInf, &opts);
    one("hiz dir zero", REFL_STATUS_INVALID_ARGUMENT, &hz, &th, refl_ray{ray.origin, v3(0, 0, 0)}, kInf, &opts);
    for (float t : {kNaN, 0.0f, -1.0f, -kInf})
        one("hiz t_max", REFL_STATUS_INVALID_ARGUMENT, &hz, &th, ray, t, &opts);
    for (float c : {kNaN, -1.0f, -kInf}) {
        const refl_trace_thickness t{c, none};
        one("hiz thickness", REFL_STATUS_INVALID_ARGUMENT, &hz, &t, ray, kInf, &opts);
    }
    refl_trace_thickness tb = thb;
    tb.back_faces.width = w - 1;
    one("hiz back faces size", REFL_STATUS_INVALID_ARGUMENT, &hz, &tb, ray, kInf, &opts);
    tb = thb;
    tb.back_faces.len = 3;
    one("hiz back faces short", REFL_STATUS_INSUFFICIENT_SIZE, &hz, &tb, ray, kInf, &opts);

    // A batch: the whole output array stays untouched on error.
    const size_t count = 5;
    std::vector<refl_ray> rays(count, ray);
    rays[1].origin = v3(0.5f, 1.0f, 2.0f);
    std::vector<float> t_max(count, 50.0f);
    auto batch = [&](const char* what, refl_status want, size_t out_len, const refl_ray* r, size_t rc,
                     const float* t, size_t tc, const refl_hiz* z, const refl_trace_thickness* tk,
                     const refl_hiz_options* o, bool null_out = false) {
        std::vector<refl_trace_result> out(count + 1);
        std::memset(static_cast<void*>(out.data()), 0xA5, out.size() * sizeof(refl_trace_result));
        std::vector<unsigned char> before(out.size() * sizeof(refl_trace_result));
        std::memcpy(before.data(), out.data(), before.size());
        const uint32_t got = refl_hiz_trace_rays(null_out ? nullptr : out.data(), out_len, z, tk, r, rc, t, tc, o);
        ++check::checks();
        const bool same = std::memcmp(before.data(), out.data(), before.size()) == 0;
        if (got != static_cast<uint32_t>(want) || (want != REFL_STATUS_OK && !same) ||
            (want == REFL_STATUS_OK && same))
            check::fail(__FILE__, __LINE__,
                        std::string("hiz_trace_rays ") + what + ": got " + check::status_name(got) +
                            ", expected " + check::status_name(want));
        if (want == REFL_STATUS_OK)
            CHECK(std::memcmp(before.data() + count * sizeof(refl_trace_result),
                              reinterpret_cast<unsigned char*>(out.data()) + count * sizeof(refl_trace_result),
                              sizeof(refl_trace_result)) == 0);
    };
    batch("ok", REFL_STATUS_OK, count, rays.data(), count, t_max.data(), count, &hz, &th, &opts);
    batch("ok one t_max", REFL_STATUS_OK, count, rays.data(), count, t_max.data(), 1, &hz, &thb, &opts);
    batch("NULL out", REFL_STATUS_NULL_POINTER, count, rays.data(), count, t_max.data(), count, &hz, &th, &opts,
          true);
    batch("NULL rays", REFL_STATUS_NULL_POINTER, count, nullptr, count, t_max.data(), count, &hz, &th, &opts);
    batch("NULL t_max", REFL_STATUS_NULL_POINTER, count, rays.data(), count, nullptr, count, &hz, &th, &opts);
    batch("NULL pyramid", REFL_STATUS_NULL_POINTER, count, rays.data(), count, t_max.data(), count, nullptr, &th,
          &opts);
    batch("NULL thickness", REFL_STATUS_NULL_POINTER, count, rays.data(), count, t_max.data(), count, &hz,
          nullptr, &opts);
    batch("NULL options", REFL_STATUS_NULL_POINTER, count, rays.data(), count, t_max.data(), count, &hz, &th,
          nullptr);
    batch("out short", REFL_STATUS_INSUFFICIENT_SIZE, count - 1, rays.data(), count, t_max.data(), count, &hz,
          &th, &opts);
    batch("t_max short", REFL_STATUS_INSUFFICIENT_SIZE, count, rays.data(), count, t_max.data(), 2, &hz, &th,
          &opts);
    {
        // The output array is written in place: it must not overlap an input.
        std::vector<refl_trace_result> out(count);
        std::memset(static_cast<void*>(out.data()), 0xA5, out.size() * sizeof(refl_trace_result));
        const auto* aliased = reinterpret_cast<const refl_ray*>(out.data());
        CHECK_STATUS(refl_hiz_trace_rays(out.data(), count, &hz, &th, aliased, count, t_max.data(), count, &opts),
                     REFL_STATUS_INVALID_ARGUMENT);
    }
    batch("t_max count 0", REFL_STATUS_INVALID_ARGUMENT, count, rays.data(), count, t_max.data(), 0, &hz, &th,
          &opts);
    bad = hz;
    bad.convention = 9;
    batch("convention", REFL_STATUS_INVALID_ARGUMENT, count, rays.data(), count, t_max.data(), count, &bad, &th,
          &opts);
    for (const refl_vec3& v : kBadVec3) {
        std::vector<refl_ray> r = rays;
        r[count - 1].dir = v;
        batch("NaN ray", REFL_STATUS_INVALID_ARGUMENT, count, r.data(), count, t_max.data(), count, &hz, &th,
              &opts);
    }
    std::vector<float> bad_t = t_max;
    bad_t[2] = kNaN;
    batch("NaN t_max", REFL_STATUS_INVALID_ARGUMENT, count, rays.data(), count, bad_t.data(), count, &hz, &th,
          &opts);
    batch("huge count", REFL_STATUS_INVALID_ARGUMENT, SIZE_MAX, rays.data(), SIZE_MAX / 2, t_max.data(), 1, &hz,
          &th, &opts);
}


// TCRR (seed 000): the scalar exports with NULL/NaN/unknown enums, and the
// passes with NULL data, short buffers, bad conventions, bad parameters and
// bad row ranges; image outputs must stay byte-identical on every error.
void tcrr_functions() {
    // Scalars.
    const refl_tcrr_options dp = refl_tcrr_options_default();
    CHECK_EQ(dp.max_iterations, 64u);
    CHECK_EQ(expect_ok<size_t>("tcrr frame bytes", [](size_t* o) { return refl_tcrr_frame_bytes(o, 4, 3); }),
             size_t(12) * REFL_TCRR_BYTES_PER_PIXEL);
    expect<size_t>("tcrr frame bytes 0", REFL_STATUS_INVALID_ARGUMENT,
                   [](size_t* o) { return refl_tcrr_frame_bytes(o, 0, 3); });
    expect<size_t>("tcrr frame bytes overflow", REFL_STATUS_INVALID_ARGUMENT,
                   [](size_t* o) { return refl_tcrr_frame_bytes(o, kMax, kMax); });
    const refl_vec3 eye = v3(0, 2, 1), w = v3(0, 0, 0), n = v3(0, 1, 0), r = v3(1, 1.5f, -2);
    expect_ok<float>("tcrr distance", [&](float* o) {
        return refl_tcrr_reflection_distance(o, eye, w, n, r, REFL_TCRR_REFLECTED_POINT);
    });
    expect_ok<float>("tcrr distance dir", [&](float* o) {
        return refl_tcrr_reflection_distance(o, eye, w, n, r, REFL_TCRR_REFLECTED_DIRECTION);
    });
    for (refl_vec3 b : {v3(kNaN, 0, 0), v3(0, kInf, 0), v3(0, 0, -kInf)}) {
        expect<float>("tcrr distance eye", REFL_STATUS_INVALID_ARGUMENT,
                      [&](float* o) { return refl_tcrr_reflection_distance(o, b, w, n, r, 0); });
        expect<float>("tcrr distance surface", REFL_STATUS_INVALID_ARGUMENT,
                      [&](float* o) { return refl_tcrr_reflection_distance(o, eye, b, n, r, 0); });
        expect<float>("tcrr distance normal", REFL_STATUS_INVALID_ARGUMENT,
                      [&](float* o) { return refl_tcrr_reflection_distance(o, eye, w, b, r, 0); });
        expect<float>("tcrr distance reflected", REFL_STATUS_INVALID_ARGUMENT,
                      [&](float* o) { return refl_tcrr_reflection_distance(o, eye, w, n, b, 1); });
    }
    for (uint32_t k : {2u, 0x80000000u, kMax})
        expect<float>("tcrr distance kind", REFL_STATUS_INVALID_ARGUMENT,
                      [&](float* o) { return refl_tcrr_reflection_distance(o, eye, w, n, r, k); });
    expect<float>("tcrr distance zero normal", REFL_STATUS_DEGENERATE_GEOMETRY,
                  [&](float* o) { return refl_tcrr_reflection_distance(o, eye, w, v3(0, 0, 0), r, 0); });
    expect<float>("tcrr distance R on the plane", REFL_STATUS_DEGENERATE_GEOMETRY,
                  [&](float* o) { return refl_tcrr_reflection_distance(o, eye, w, n, v3(1, 0, 0), 0); });
    expect<float>("tcrr distance eye behind", REFL_STATUS_DEGENERATE_GEOMETRY,
                  [&](float* o) { return refl_tcrr_reflection_distance(o, v3(0, -1, 0), w, n, r, 0); });
    expect_ok<float>("tcrr fresnel", [](float* o) { return refl_tcrr_fresnel_weight(o, 0.5f, 0.5f, 1); });
    for (uint32_t m : {2u, kMax})
        expect<float>("tcrr fresnel mode", REFL_STATUS_INVALID_ARGUMENT,
                      [&](float* o) { return refl_tcrr_fresnel_weight(o, 0.5f, 0.5f, m); });
    CHECK(expect_ok<bool>("tcrr key frame", [](bool* o) { return refl_tcrr_needs_key_frame(o, 0.3f, 31, 100); }));
    for (float t : {kNaN, -0.1f, 1.5f, kInf})
        expect<bool>("tcrr key frame threshold", REFL_STATUS_INVALID_ARGUMENT,
                     [&](bool* o) { return refl_tcrr_needs_key_frame(o, t, 1, 2); });
    expect<bool>("tcrr key frame retrace > reflective", REFL_STATUS_INVALID_ARGUMENT,
                 [](bool* o) { return refl_tcrr_needs_key_frame(o, 0.3f, 3, 2); });

    // A small key frame: a mirror plane facing the camera.
    const refl_camera g = good_camera();
    const uint32_t W = g.width, H = g.height;
    const size_t N = size_t(W) * H;
    std::vector<float> depth(N, 4.0f), spec(N, 0.9f), dist(N, 2.0f);
    std::vector<refl_vec3> normal(N, v3(0.2f, 0.4f, 0.9f)), color(N, v3(0.5f, 0.5f, 0.5f));
    refl_tcrr_key key{};
    key.camera = g;
    key.convention = REFL_DEPTH_CONVENTION_LINEAR;
    key.depth = {depth.data(), N, W, H, W};
    key.normal = {normal.data(), N, W, H, W};
    key.specular = {spec.data(), N, W, H, W};
    key.color = {color.data(), N, W, H, W};
    key.distance = {dist.data(), N, W, H, W};
    key.surfels = {nullptr, 0, W, H, W};
    refl_tcrr_current cur{};
    cur.camera = g;
    cur.convention = REFL_DEPTH_CONVENTION_LINEAR;
    cur.depth = key.depth;
    cur.specular = key.specular;
    const refl_row_range all{0, H};
    const refl_row_range bad_rows[] = {{0, H + 1}, {5, 4}, {kMax, kMax}};
    std::vector<refl_tcrr_key> bad_keys;
    auto bad_key = [&](auto edit) {
        refl_tcrr_key k = key;
        edit(k);
        bad_keys.push_back(k);
    };
    bad_key([](refl_tcrr_key& k) { k.convention = 3; });
    bad_key([](refl_tcrr_key& k) { k.convention = kMax; });
    bad_key([](refl_tcrr_key& k) { k.depth.data = nullptr; });
    bad_key([](refl_tcrr_key& k) { k.normal.len -= 1; });
    bad_key([](refl_tcrr_key& k) { k.color.width -= 1; });
    bad_key([](refl_tcrr_key& k) { k.distance.stride = 1; });
    bad_key([](refl_tcrr_key& k) { k.camera.fov_y = kNaN; });
    bad_key([](refl_tcrr_key& k) { k.specular.height = 0; });
    std::vector<refl_tcrr_options> bad_params;
    auto bad_param = [&](auto edit) {
        refl_tcrr_options p = dp;
        edit(p);
        bad_params.push_back(p);
    };
    bad_param([](refl_tcrr_options& p) { p.max_iterations = 0; });
    bad_param([](refl_tcrr_options& p) { p.magnification = kNaN; });
    bad_param([](refl_tcrr_options& p) { p.magnification = 0.5f; });
    bad_param([](refl_tcrr_options& p) { p.discontinuity = -1.0f; });
    bad_param([](refl_tcrr_options& p) { p.reflected_discontinuity = kInf; });
    bad_param([](refl_tcrr_options& p) { p.retrace_contrast = kNaN; });
    bad_param([](refl_tcrr_options& p) { p.retrace_contrast = 0.0f; });

    // Runs `f` on sentinel-filled image outputs and checks they stay intact.
    auto intact = [](const char* what, refl_status want, auto& bufs, auto f) {
        for (auto* b : bufs) std::memset(b->data(), 0x5A, b->size() * sizeof((*b)[0]));
        const uint32_t got = f();
        ++check::checks();
        bool same = true;
        for (auto* b : bufs) {
            const unsigned char* p = reinterpret_cast<const unsigned char*>(b->data());
            for (size_t i = 0; i < b->size() * sizeof((*b)[0]); ++i) same = same && p[i] == 0x5A;
        }
        if (got != static_cast<uint32_t>(want) || !same)
            check::fail(__FILE__, __LINE__,
                        std::string(what) + ": got " + check::status_name(got) + ", expected " +
                            check::status_name(want) + (same ? "" : ", and the output was written"));
    };

    // refl_tcrr_prepare
    std::vector<refl_tcrr_surfel> surfels(N);
    {
        std::vector<std::vector<refl_tcrr_surfel>*> bufs{&surfels};
        auto run = [&](refl_image_tcrr_surfel_mut img, const refl_tcrr_key* k, refl_row_range rr) {
            return [=] { return refl_tcrr_prepare(img, nullptr, k, rr); };
        };
        const refl_image_tcrr_surfel_mut good{surfels.data(), N, W, H, W};
        intact("tcrr prepare NULL key", REFL_STATUS_NULL_POINTER, bufs, run(good, nullptr, all));
        intact("tcrr prepare NULL data", REFL_STATUS_NULL_POINTER, bufs,
               run({nullptr, N, W, H, W}, &key, all));
        intact("tcrr prepare short", REFL_STATUS_INSUFFICIENT_SIZE, bufs, run({surfels.data(), N - 1, W, H, W}, &key, all));
        intact("tcrr prepare size mismatch", REFL_STATUS_INVALID_ARGUMENT, bufs,
               run({surfels.data(), N, W - 1, H, W}, &key, {0, 1}));
        intact("tcrr prepare misaligned", REFL_STATUS_INVALID_ARGUMENT, bufs,
               run({reinterpret_cast<refl_tcrr_surfel*>(reinterpret_cast<unsigned char*>(surfels.data()) + 1), N - 1, W, H, W},
                   &key, all));
        for (const refl_row_range& rr : bad_rows)
            intact("tcrr prepare rows", REFL_STATUS_INVALID_ARGUMENT, bufs, run(good, &key, rr));
        for (const refl_tcrr_key& k : bad_keys) {
            const uint32_t st = refl_tcrr_prepare(good, nullptr, &k, all);
            CHECK(st != REFL_STATUS_OK);
        }
        uint32_t reflective = 0;
        CHECK_STATUS(refl_tcrr_prepare(good, &reflective, &key, all), REFL_STATUS_OK);
        CHECK(reflective > 0);
    }
    refl_tcrr_key fast = key;
    fast.surfels = {surfels.data(), N, W, H, W};

    // refl_tcrr_reset_offsets and refl_tcrr_search
    std::vector<refl_vec2> offsets(N);
    {
        std::vector<std::vector<refl_vec2>*> bufs{&offsets};
        const refl_image_vec2_mut good{offsets.data(), N, W, H, W};
        intact("tcrr reset NULL", REFL_STATUS_NULL_POINTER, bufs,
               [&] { return refl_tcrr_reset_offsets({nullptr, N, W, H, W}, all); });
        intact("tcrr reset short", REFL_STATUS_INSUFFICIENT_SIZE, bufs,
               [&] { return refl_tcrr_reset_offsets({offsets.data(), N - 1, W, H, W}, all); });
        for (const refl_row_range& rr : bad_rows)
            intact("tcrr reset rows", REFL_STATUS_INVALID_ARGUMENT, bufs, [&] { return refl_tcrr_reset_offsets(good, rr); });
        auto search = [&](refl_image_vec2_mut o, const refl_tcrr_key* k, refl_vec3 e, const refl_tcrr_options* p,
                          refl_row_range rr) { return [=] { return refl_tcrr_search(o, nullptr, k, e, p, rr); }; };
        const refl_vec3 e = v3(1.1f, 2.0f, 4.9f);
        intact("tcrr search NULL key", REFL_STATUS_NULL_POINTER, bufs, search(good, nullptr, e, &dp, all));
        intact("tcrr search NULL params", REFL_STATUS_NULL_POINTER, bufs, search(good, &key, e, nullptr, all));
        intact("tcrr search NULL offsets", REFL_STATUS_NULL_POINTER, bufs,
               search({nullptr, N, W, H, W}, &key, e, &dp, all));
        intact("tcrr search short", REFL_STATUS_INSUFFICIENT_SIZE, bufs,
               search({offsets.data(), N - 1, W, H, W}, &key, e, &dp, all));
        for (refl_vec3 b : {v3(kNaN, 0, 0), v3(0, kInf, 0)})
            intact("tcrr search eye", REFL_STATUS_INVALID_ARGUMENT, bufs, search(good, &key, b, &dp, all));
        for (const refl_row_range& rr : bad_rows)
            intact("tcrr search rows", REFL_STATUS_INVALID_ARGUMENT, bufs, search(good, &key, e, &dp, rr));
        for (const refl_tcrr_options& p : bad_params)
            intact("tcrr search params", REFL_STATUS_INVALID_ARGUMENT, bufs, search(good, &key, e, &p, all));
        for (const refl_tcrr_key& k : bad_keys) {
            for (auto* b : bufs) std::memset(b->data(), 0x5A, b->size() * sizeof((*b)[0]));
            CHECK(refl_tcrr_search(good, nullptr, &k, e, &dp, all) != REFL_STATUS_OK);
            const unsigned char* p = reinterpret_cast<const unsigned char*>(offsets.data());
            bool same = true;
            for (size_t i = 0; i < N * sizeof(refl_vec2); ++i) same = same && p[i] == 0x5A;
            CHECK(same);
        }
        CHECK_STATUS(refl_tcrr_reset_offsets(good, all), REFL_STATUS_OK);
        refl_tcrr_search_stats st{};
        CHECK_STATUS(refl_tcrr_search(good, &st, &fast, e, &dp, all), REFL_STATUS_OK);
        CHECK(st.reflective > 0);
    }

    // refl_tcrr_shift
    std::vector<refl_vec3> inter(N);
    std::vector<float> idepth(N);
    std::vector<uint8_t> coverage(N);
    {
        auto shift = [&](refl_image_vec3_mut c, refl_image_f32_mut d, refl_image_u8_mut v, const refl_tcrr_key* k,
                         refl_image_vec2 o, const refl_tcrr_options* p, refl_row_range rr) {
            return [=] { return refl_tcrr_shift(c, d, v, nullptr, k, o, p, rr); };
        };
        const refl_image_vec3_mut c{inter.data(), N, W, H, W};
        const refl_image_f32_mut d{idepth.data(), N, W, H, W};
        const refl_image_u8_mut v{coverage.data(), N, W, H, W};
        const refl_image_vec2 o{offsets.data(), N, W, H, W};
        std::vector<std::vector<refl_vec3>*> b1{&inter};
        std::vector<std::vector<float>*> b2{&idepth};
        std::vector<std::vector<uint8_t>*> b3{&coverage};
        auto all_intact = [&](const char* what, refl_status want, auto f) {
            std::memset(idepth.data(), 0x5A, N * sizeof(float));
            std::memset(coverage.data(), 0x5A, N);
            intact(what, want, b1, f);
            for (size_t i = 0; i < N; ++i) {
                uint32_t bits;
                std::memcpy(&bits, &idepth[i], 4);
                CHECK(bits == 0x5A5A5A5Au && coverage[i] == 0x5A);
                if (bits != 0x5A5A5A5Au || coverage[i] != 0x5A) break;
            }
        };
        (void)b2;
        (void)b3;
        all_intact("tcrr shift NULL key", REFL_STATUS_NULL_POINTER, shift(c, d, v, nullptr, o, &dp, all));
        all_intact("tcrr shift NULL params", REFL_STATUS_NULL_POINTER, shift(c, d, v, &key, o, nullptr, all));
        all_intact("tcrr shift NULL color", REFL_STATUS_NULL_POINTER,
                   shift({nullptr, N, W, H, W}, d, v, &key, o, &dp, all));
        all_intact("tcrr shift NULL depth", REFL_STATUS_NULL_POINTER,
                   shift(c, {nullptr, N, W, H, W}, v, &key, o, &dp, all));
        all_intact("tcrr shift NULL coverage", REFL_STATUS_NULL_POINTER,
                   shift(c, d, {nullptr, N, W, H, W}, &key, o, &dp, all));
        all_intact("tcrr shift NULL offsets", REFL_STATUS_NULL_POINTER,
                   shift(c, d, v, &key, {nullptr, N, W, H, W}, &dp, all));
        all_intact("tcrr shift short coverage", REFL_STATUS_INSUFFICIENT_SIZE,
                   shift(c, d, {coverage.data(), N - 1, W, H, W}, &key, o, &dp, all));
        all_intact("tcrr shift short offsets", REFL_STATUS_INSUFFICIENT_SIZE,
                   shift(c, d, v, &key, {offsets.data(), 3, W, H, W}, &dp, all));
        all_intact("tcrr shift size mismatch", REFL_STATUS_INVALID_ARGUMENT,
                   shift(c, {idepth.data(), N, W - 1, H, W}, v, &key, o, &dp, all));
        for (const refl_row_range& rr : bad_rows)
            all_intact("tcrr shift rows", REFL_STATUS_INVALID_ARGUMENT, shift(c, d, v, &key, o, &dp, rr));
        for (const refl_tcrr_options& p : bad_params)
            all_intact("tcrr shift params", REFL_STATUS_INVALID_ARGUMENT, shift(c, d, v, &key, o, &p, all));
        for (const refl_tcrr_key& k : bad_keys) CHECK(shift(c, d, v, &k, o, &dp, all)() != REFL_STATUS_OK);
        CHECK_STATUS(shift(c, d, v, &fast, o, &dp, all)(), REFL_STATUS_OK);
    }

    // refl_tcrr_warp, refl_tcrr_retrace_list, refl_tcrr_compose
    std::vector<refl_vec3> warped(N);
    std::vector<uint8_t> mask(N);
    {
        const refl_image_vec3_mut c{warped.data(), N, W, H, W};
        const refl_image_u8_mut m{mask.data(), N, W, H, W};
        const refl_image_vec3 src{inter.data(), N, W, H, W};
        const refl_image_f32 sd{idepth.data(), N, W, H, W};
        const refl_image_u8 cov{coverage.data(), N, W, H, W};
        auto warp = [&](refl_image_vec3_mut cc, refl_image_u8_mut mm, const refl_tcrr_current* cu,
                        const refl_tcrr_key* k, refl_image_u8 cv, const refl_tcrr_options* p, refl_row_range rr) {
            return [=] { return refl_tcrr_warp(cc, mm, nullptr, cu, k, src, sd, cv, p, rr); };
        };
        std::vector<std::vector<refl_vec3>*> b1{&warped};
        auto both_intact = [&](const char* what, refl_status want, auto f) {
            std::memset(mask.data(), 0x5A, N);
            intact(what, want, b1, f);
            bool same = true;
            for (size_t i = 0; i < N; ++i) same = same && mask[i] == 0x5A;
            CHECK(same);
        };
        both_intact("tcrr warp NULL current", REFL_STATUS_NULL_POINTER, warp(c, m, nullptr, &key, cov, &dp, all));
        both_intact("tcrr warp NULL key", REFL_STATUS_NULL_POINTER, warp(c, m, &cur, nullptr, cov, &dp, all));
        both_intact("tcrr warp NULL params", REFL_STATUS_NULL_POINTER, warp(c, m, &cur, &key, cov, nullptr, all));
        both_intact("tcrr warp NULL mask", REFL_STATUS_NULL_POINTER,
                    warp(c, {nullptr, N, W, H, W}, &cur, &key, cov, &dp, all));
        both_intact("tcrr warp NULL coverage", REFL_STATUS_NULL_POINTER,
                    warp(c, m, &cur, &key, {nullptr, N, W, H, W}, &dp, all));
        both_intact("tcrr warp short mask", REFL_STATUS_INSUFFICIENT_SIZE,
                    warp(c, {mask.data(), N - 1, W, H, W}, &cur, &key, cov, &dp, all));
        refl_tcrr_current bad_cur = cur;
        bad_cur.convention = 7;
        both_intact("tcrr warp convention", REFL_STATUS_INVALID_ARGUMENT, warp(c, m, &bad_cur, &key, cov, &dp, all));
        bad_cur = cur;
        bad_cur.specular.width = 3;
        both_intact("tcrr warp size mismatch", REFL_STATUS_INVALID_ARGUMENT, warp(c, m, &bad_cur, &key, cov, &dp, all));
        for (const refl_row_range& rr : bad_rows)
            both_intact("tcrr warp rows", REFL_STATUS_INVALID_ARGUMENT, warp(c, m, &cur, &key, cov, &dp, rr));
        for (const refl_tcrr_options& p : bad_params)
            both_intact("tcrr warp params", REFL_STATUS_INVALID_ARGUMENT, warp(c, m, &cur, &key, cov, &p, all));
        for (const refl_tcrr_key& k : bad_keys) CHECK(warp(c, m, &cur, &k, cov, &dp, all)() != REFL_STATUS_OK);
        refl_tcrr_warp_stats ws{};
        CHECK_STATUS(refl_tcrr_warp(c, m, &ws, &cur, &fast, src, sd, cov, &dp, all), REFL_STATUS_OK);
        CHECK(ws.reflective > 0);

        const refl_image_u8 mv{mask.data(), N, W, H, W};
        const size_t count =
            expect_ok<size_t>("tcrr list count", [&](size_t* o) { return refl_tcrr_retrace_list(nullptr, 0, o, mv); });
        expect<size_t>("tcrr list NULL mask", REFL_STATUS_NULL_POINTER,
                       [&](size_t* o) { return refl_tcrr_retrace_list(nullptr, 0, o, {nullptr, N, W, H, W}); }, false);
        expect<size_t>("tcrr list short mask", REFL_STATUS_INSUFFICIENT_SIZE,
                       [&](size_t* o) { return refl_tcrr_retrace_list(nullptr, 0, o, {mask.data(), N - 1, W, H, W}); });
        std::vector<uint8_t> everything(N, REFL_TCRR_MASK_RETRACE);
        std::vector<uint32_t> list(4, 0x5A5A5A5Au);
        expect<size_t>("tcrr list too short", REFL_STATUS_INSUFFICIENT_SIZE, [&](size_t* o) {
            return refl_tcrr_retrace_list(list.data(), list.size(), o, {everything.data(), N, W, H, W});
        });
        expect<size_t>("tcrr list misaligned", REFL_STATUS_INVALID_ARGUMENT, [&](size_t* o) {
            return refl_tcrr_retrace_list(
                reinterpret_cast<uint32_t*>(reinterpret_cast<unsigned char*>(list.data()) + 1), 2, o,
                {everything.data(), N, W, H, W});
        });
        for (uint32_t v : list) CHECK_EQ(v, 0x5A5A5A5Au);
        std::vector<uint32_t> full(count + 1);
        CHECK_EQ(expect_ok<size_t>("tcrr list", [&](size_t* o) { return refl_tcrr_retrace_list(full.data(), full.size(), o, mv); }),
                 count);

        std::vector<refl_vec3> out(N);
        std::vector<std::vector<refl_vec3>*> bo{&out};
        const refl_image_vec3_mut om{out.data(), N, W, H, W};
        const refl_image_vec3 dif{color.data(), N, W, H, W}, nrm{normal.data(), N, W, H, W};
        const refl_image_vec3 refl{warped.data(), N, W, H, W};
        auto compose = [&](refl_image_vec3_mut o, refl_image_vec3 d, const refl_tcrr_current* cu, uint32_t mode,
                           refl_row_range rr) { return [=] { return refl_tcrr_compose(o, d, refl, nrm, cu, mode, rr); }; };
        intact("tcrr compose NULL current", REFL_STATUS_NULL_POINTER, bo, compose(om, dif, nullptr, 1, all));
        intact("tcrr compose NULL out", REFL_STATUS_NULL_POINTER, bo, compose({nullptr, N, W, H, W}, dif, &cur, 1, all));
        intact("tcrr compose NULL diffuse", REFL_STATUS_NULL_POINTER, bo,
               compose(om, {nullptr, N, W, H, W}, &cur, 1, all));
        intact("tcrr compose short diffuse", REFL_STATUS_INSUFFICIENT_SIZE, bo,
               compose(om, {color.data(), N - 1, W, H, W}, &cur, 1, all));
        for (uint32_t mode : {2u, kMax})
            intact("tcrr compose mode", REFL_STATUS_INVALID_ARGUMENT, bo, compose(om, dif, &cur, mode, all));
        for (const refl_row_range& rr : bad_rows)
            intact("tcrr compose rows", REFL_STATUS_INVALID_ARGUMENT, bo, compose(om, dif, &cur, 1, rr));
        CHECK_STATUS(compose(om, dif, &cur, REFL_TCRR_FRESNEL_SCHLICK, all)(), REFL_STATUS_OK);
    }
}

// Seed 003 clusters: parameter defaults, bins, per-band counts and ids,
// ranges, cluster cameras, lobe angles and finalization; every error leaves
// every output byte untouched.
void cluster_functions() {
    const uint32_t W = 16, H = 12;
    const size_t N = size_t(W) * H;
    std::vector<refl_vec3> pos(N), nrm(N, v3(0, 1, 0));
    std::vector<uint32_t> obj(N, 0);
    for (uint32_t y = 0; y < H; ++y)
        for (uint32_t x = 0; x < W; ++x) pos[y * W + x] = v3(0.1f * float(x) - 0.8f, 0.0f, 0.1f * float(y) - 1.5f);
    const refl_vec3 eye = v3(0.0f, 2.0f, 3.0f);
    const refl_image_vec3 pv{pos.data(), N, W, H, W}, nv{nrm.data(), N, W, H, W};
    const refl_image_u32 ov{obj.data(), N, W, H, W};
    const refl_row_range all{0, H};
    // Generic "status and untouched bytes" check over raw regions.
    struct Region {
        void* p;
        size_t bytes;
    };
    auto intact = [](const char* what, refl_status want, std::initializer_list<Region> regions, auto f) {
        for (const Region& r : regions) std::memset(r.p, 0x5A, r.bytes);
        const uint32_t got = f();
        ++check::checks();
        bool same = true;
        for (const Region& r : regions)
            for (size_t i = 0; i < r.bytes; ++i) same = same && static_cast<unsigned char*>(r.p)[i] == 0x5A;
        if (got != static_cast<uint32_t>(want) || !same)
            check::fail(__FILE__, __LINE__,
                        std::string(what) + ": got " + check::status_name(got) + ", expected " +
                            check::status_name(want) + (same ? "" : ", and the output was written"));
    };

    // Defaults and bins.
    const refl_cluster_options cp = refl_cluster_options_default();
    CHECK(cp.max_theta_bins == 13 && cp.max_phi_bins == 8 && cp.gain == 1.0f);
    refl_cluster_camera_options kp = refl_cluster_camera_options_default();
    kp.far_distance = 20.0f;
    const uint32_t bmax = expect_ok<uint32_t>("bins max", [&](uint32_t* o) { return refl_cluster_bins_max(o, 1, &cp); });
    CHECK_EQ(bmax, 104u);
    expect<uint32_t>("bins max overflow", REFL_STATUS_INVALID_ARGUMENT,
                     [&](uint32_t* o) { return refl_cluster_bins_max(o, kMax, &cp); });
    expect<uint32_t>("bins max NULL params", REFL_STATUS_NULL_POINTER,
                     [&](uint32_t* o) { return refl_cluster_bins_max(o, 1, nullptr); }, false);
    for (float g : {kNaN, kInf, 0.0f, -1.0f}) {
        refl_cluster_options b = cp;
        b.gain = g;
        expect<uint32_t>("bins max gain", REFL_STATUS_INVALID_ARGUMENT,
                         [&](uint32_t* o) { return refl_cluster_bins_max(o, 1, &b); }, false);
    }
    for (uint32_t t : {0u, 1025u, kMax}) {
        refl_cluster_options b = cp;
        b.max_theta_bins = t;
        expect<uint32_t>("bins max theta", REFL_STATUS_INVALID_ARGUMENT,
                         [&](uint32_t* o) { return refl_cluster_bins_max(o, 1, &b); }, false);
    }

    // Counts.
    std::vector<uint32_t> counts(1, 0);
    CHECK_STATUS(refl_cluster_count_objects(counts.data(), 1, ov, all), REFL_STATUS_OK);
    CHECK_EQ(counts[0], uint32_t(N));
    std::vector<uint32_t> cbuf(2);
    const Region cr{cbuf.data(), cbuf.size() * 4};
    intact("count NULL counts", REFL_STATUS_NULL_POINTER, {cr},
           [&] { return refl_cluster_count_objects(nullptr, 2, ov, all); });
    intact("count NULL objects", REFL_STATUS_NULL_POINTER, {cr},
           [&] { return refl_cluster_count_objects(cbuf.data(), 2, {nullptr, N, W, H, W}, all); });
    intact("count short objects", REFL_STATUS_INSUFFICIENT_SIZE, {cr},
           [&] { return refl_cluster_count_objects(cbuf.data(), 2, {obj.data(), N - 1, W, H, W}, all); });
    for (refl_row_range r : {refl_row_range{0, H + 1}, refl_row_range{3, 3}, refl_row_range{4, 2}})
        intact("count rows", REFL_STATUS_INVALID_ARGUMENT, {cr},
               [&] { return refl_cluster_count_objects(cbuf.data(), 2, ov, r); });
    intact("count misaligned", REFL_STATUS_INVALID_ARGUMENT, {cr}, [&] {
        return refl_cluster_count_objects(
            reinterpret_cast<uint32_t*>(reinterpret_cast<unsigned char*>(cbuf.data()) + 1), 1, ov, all);
    });
    intact("count overflow", REFL_STATUS_INSUFFICIENT_SIZE, {cr}, [&] {
        uint32_t big[1] = {kMax - 3};
        const uint32_t st = refl_cluster_count_objects(big, 1, ov, all);
        CHECK(big[0] == kMax - 3);
        return st;
    });

    // Layout.
    refl_cluster_object_bins layout[1];
    uint32_t total = 0;
    CHECK_STATUS(refl_cluster_bin_layout(&total, layout, 1, counts.data(), 1, N, &cp), REFL_STATUS_OK);
    CHECK(total >= 1 && total <= bmax);
    std::vector<refl_cluster_object_bins> lbuf(2);
    uint32_t tbuf = 0;
    const Region lr{lbuf.data(), lbuf.size() * sizeof(refl_cluster_object_bins)}, tr{&tbuf, 4};
    intact("layout NULL total", REFL_STATUS_NULL_POINTER, {lr},
           [&] { return refl_cluster_bin_layout(nullptr, lbuf.data(), 2, counts.data(), 1, N, &cp); });
    intact("layout NULL out", REFL_STATUS_NULL_POINTER, {tr},
           [&] { return refl_cluster_bin_layout(&tbuf, nullptr, 2, counts.data(), 1, N, &cp); });
    intact("layout NULL counts", REFL_STATUS_NULL_POINTER, {lr, tr},
           [&] { return refl_cluster_bin_layout(&tbuf, lbuf.data(), 2, nullptr, 1, N, &cp); });
    intact("layout NULL params", REFL_STATUS_NULL_POINTER, {lr, tr},
           [&] { return refl_cluster_bin_layout(&tbuf, lbuf.data(), 2, counts.data(), 1, N, nullptr); });
    intact("layout short out", REFL_STATUS_INSUFFICIENT_SIZE, {lr, tr},
           [&] { return refl_cluster_bin_layout(&tbuf, lbuf.data(), 0, counts.data(), 1, N, &cp); });
    intact("layout zero frame", REFL_STATUS_INVALID_ARGUMENT, {lr, tr},
           [&] { return refl_cluster_bin_layout(&tbuf, lbuf.data(), 2, counts.data(), 1, 0, &cp); });
    intact("layout counts above frame", REFL_STATUS_INVALID_ARGUMENT, {lr, tr},
           [&] { return refl_cluster_bin_layout(&tbuf, lbuf.data(), 2, counts.data(), 1, N - 1, &cp); });

    // Ids per band.
    std::vector<uint32_t> ids(N, 7);
    const refl_image_u32_mut im{ids.data(), N, W, H, W};
    CHECK_STATUS(refl_cluster_assign(im, refl_row_range{0, 5}, nv, ov, layout, 1), REFL_STATUS_OK);
    CHECK_STATUS(refl_cluster_assign(im, refl_row_range{5, H}, nv, ov, layout, 1), REFL_STATUS_OK);
    for (uint32_t v : ids) CHECK(v < total);
    std::vector<uint32_t> ibuf(N);
    const refl_image_u32_mut ib{ibuf.data(), N, W, H, W};
    const Region ir{ibuf.data(), N * 4};
    std::vector<refl_vec3> bad_n = nrm;
    bad_n[N / 2] = v3(kNaN, 1, 0);
    intact("assign NaN normal", REFL_STATUS_INVALID_ARGUMENT, {ir},
           [&] { return refl_cluster_assign(ib, all, {bad_n.data(), N, W, H, W}, ov, layout, 1); });
    bad_n[N / 2] = v3(0, 0, 0);
    intact("assign zero normal", REFL_STATUS_INVALID_ARGUMENT, {ir},
           [&] { return refl_cluster_assign(ib, all, {bad_n.data(), N, W, H, W}, ov, layout, 1); });
    intact("assign NULL layout", REFL_STATUS_NULL_POINTER, {ir},
           [&] { return refl_cluster_assign(ib, all, nv, ov, nullptr, 1); });
    intact("assign NULL ids", REFL_STATUS_NULL_POINTER, {ir},
           [&] { return refl_cluster_assign({nullptr, N, W, H, W}, all, nv, ov, layout, 1); });
    intact("assign NULL normals", REFL_STATUS_NULL_POINTER, {ir},
           [&] { return refl_cluster_assign(ib, all, {nullptr, N, W, H, W}, ov, layout, 1); });
    intact("assign size mismatch", REFL_STATUS_INVALID_ARGUMENT, {ir},
           [&] { return refl_cluster_assign(ib, all, {nrm.data(), N, W - 1, H, W}, ov, layout, 1); });
    intact("assign short ids", REFL_STATUS_INSUFFICIENT_SIZE, {ir},
           [&] { return refl_cluster_assign({ibuf.data(), N - 1, W, H, W}, all, nv, ov, layout, 1); });
    for (refl_row_range r : {refl_row_range{0, H + 1}, refl_row_range{2, 2}, refl_row_range{kMax, kMax}})
        intact("assign rows", REFL_STATUS_INVALID_ARGUMENT, {ir},
               [&] { return refl_cluster_assign(ib, r, nv, ov, layout, 1); });
    intact("assign ids alias normals", REFL_STATUS_INVALID_ARGUMENT, {ir}, [&] {
        return refl_cluster_assign(ib, all, {reinterpret_cast<const refl_vec3*>(ibuf.data()), N / 3, W, H / 3 - 1, W},
                                   {ov.data, N, W, H / 3 - 1, W}, layout, 1);
    });

    // Ranges.
    std::vector<uint32_t> offsets(total + 1), order(N);
    uint32_t clustered = 0;
    CHECK_STATUS(refl_cluster_ranges(&clustered, offsets.data(), offsets.size(), order.data(), N,
                                     {ids.data(), N, W, H, W}, total),
                 REFL_STATUS_OK);
    CHECK_EQ(clustered, uint32_t(N));
    std::vector<uint32_t> obuf(total + 1), rbuf(N);
    uint32_t cbuf2 = 0;
    const Region orr{obuf.data(), obuf.size() * 4}, rr{rbuf.data(), N * 4}, c2{&cbuf2, 4};
    const refl_image_u32 iv{ids.data(), N, W, H, W};
    intact("ranges short offsets", REFL_STATUS_INSUFFICIENT_SIZE, {orr, rr, c2},
           [&] { return refl_cluster_ranges(&cbuf2, obuf.data(), total, rbuf.data(), N, iv, total); });
    intact("ranges short order", REFL_STATUS_INSUFFICIENT_SIZE, {orr, rr, c2},
           [&] { return refl_cluster_ranges(&cbuf2, obuf.data(), total + 1, rbuf.data(), N - 1, iv, total); });
    intact("ranges id beyond clusters", REFL_STATUS_INVALID_ARGUMENT, {orr, rr, c2}, [&] {
        return refl_cluster_ranges(&cbuf2, obuf.data(), 1, rbuf.data(), N, iv, 0);
    });
    intact("ranges NULL total", REFL_STATUS_NULL_POINTER, {orr, rr},
           [&] { return refl_cluster_ranges(nullptr, obuf.data(), total + 1, rbuf.data(), N, iv, total); });
    intact("ranges NULL offsets", REFL_STATUS_NULL_POINTER, {rr, c2},
           [&] { return refl_cluster_ranges(&cbuf2, nullptr, total + 1, rbuf.data(), N, iv, total); });
    intact("ranges NULL ids", REFL_STATUS_NULL_POINTER, {orr, rr, c2}, [&] {
        return refl_cluster_ranges(&cbuf2, obuf.data(), total + 1, rbuf.data(), N, {nullptr, N, W, H, W}, total);
    });
    intact("ranges aliasing", REFL_STATUS_INVALID_ARGUMENT, {rr, c2},
           [&] { return refl_cluster_ranges(&cbuf2, rbuf.data(), total + 1, rbuf.data(), N, iv, total); });

    // A camera for the largest cluster (the floor is planar).
    size_t best = 0;
    for (size_t c = 0; c < total; ++c)
        if (offsets[c + 1] - offsets[c] > offsets[best + 1] - offsets[best]) best = c;
    const uint32_t* px = order.data() + offsets[best];
    const size_t pc = offsets[best + 1] - offsets[best];
    const refl_cluster_camera cam = expect_ok<refl_cluster_camera>("cluster camera", [&](refl_cluster_camera* o) {
        return refl_cluster_build_camera(o, pv, nv, px, pc, eye, &kp);
    });
    CHECK(cam.fallback == REFL_CLUSTER_FALLBACK_NONE && cam.planar && cam.f == 1.0f);
    CHECK(cam.eye0.x == 0.0f && cam.eye0.y == -2.0f && cam.eye0.z == 3.0f);
    const refl_cluster_camera one = expect_ok<refl_cluster_camera>(
        "cluster camera one pixel", [&](refl_cluster_camera* o) { return refl_cluster_build_camera(o, pv, nv, px, 1, eye, &kp); });
    CHECK(one.fallback == REFL_CLUSTER_FALLBACK_TOO_FEW_PIXELS);
    auto camera_call = [&](const char* what, refl_status want, refl_image_vec3 p, refl_image_vec3 n, const uint32_t* x,
                           size_t count, refl_vec3 e, const refl_cluster_camera_options* k) {
        expect<refl_cluster_camera>(what, want,
                                    [=](refl_cluster_camera* o) { return refl_cluster_build_camera(o, p, n, x, count, e, k); });
    };
    for (const refl_vec3& b : kBadVec3) camera_call("camera eye", REFL_STATUS_INVALID_ARGUMENT, pv, nv, px, pc, b, &kp);
    std::vector<refl_vec3> bad_p = pos;
    bad_p[px[0]] = v3(kNaN, 0, 0);
    camera_call("camera NaN position", REFL_STATUS_INVALID_ARGUMENT, {bad_p.data(), N, W, H, W}, nv, px, pc, eye, &kp);
    bad_n = nrm;
    bad_n[px[1]] = v3(0, 2, 0);
    camera_call("camera non-unit normal", REFL_STATUS_INVALID_ARGUMENT, pv, {bad_n.data(), N, W, H, W}, px, pc, eye,
                &kp);
    const uint32_t outside[] = {uint32_t(N), 0, 1, 2};
    camera_call("camera pixel outside", REFL_STATUS_INVALID_ARGUMENT, pv, nv, outside, 4, eye, &kp);
    camera_call("camera NULL pixels", REFL_STATUS_NULL_POINTER, pv, nv, nullptr, pc, eye, &kp);
    camera_call("camera NULL params", REFL_STATUS_NULL_POINTER, pv, nv, px, pc, eye, nullptr);
    camera_call("camera NULL positions", REFL_STATUS_NULL_POINTER, {nullptr, N, W, H, W}, nv, px, pc, eye, &kp);
    camera_call("camera size mismatch", REFL_STATUS_INVALID_ARGUMENT, pv, {nrm.data(), N, W, H - 1, W}, px, pc, eye,
                &kp);
    for (int k = 0; k < 6; ++k) {
        refl_cluster_camera_options b = kp;
        if (k == 0) b.far_distance = kInf;
        if (k == 1) b.far_distance = 0.0f;
        if (k == 2) b.cone_half_angle = kNaN;
        if (k == 3) b.resolution_scale = -1.0f;
        if (k == 4) b.min_pixels = 1;
        if (k == 5) b.max_f = 0.5f;
        camera_call("camera params", REFL_STATUS_INVALID_ARGUMENT, pv, nv, px, pc, eye, &b);
    }

    // Lobe angle.
    const float a = expect_ok<float>("lobe angle", [](float* o) { return refl_cluster_lobe_angle(o, 40.0f, 0.95f); });
    CHECK(a > 0.0f && a < 1.0f);
    for (float e : {kNaN, -1.0f, kInf})
        expect<float>("lobe angle exponent", REFL_STATUS_INVALID_ARGUMENT,
                      [=](float* o) { return refl_cluster_lobe_angle(o, e, 0.5f); });
    for (float e : {kNaN, 0.0f, 1.0f})
        expect<float>("lobe angle energy", REFL_STATUS_INVALID_ARGUMENT,
                      [=](float* o) { return refl_cluster_lobe_angle(o, 10.0f, e); }, false);

    // Finalize against a flat depth image of the cluster camera.
    const uint32_t dw = cam.camera.width, dh = cam.camera.height;
    const size_t dn = size_t(dw) * dh;
    std::vector<float> depth(dn, 0.5f * cam.camera.z_far);
    std::vector<refl_vec3> color(dn, v3(0.2f, 0.4f, 0.6f));
    const refl_image_f32 none{nullptr, 0, 0, 0, 0};
    const refl_depth_image di{{depth.data(), dn, dw, dh, dw}, cam.camera, REFL_DEPTH_CONVENTION_LINEAR};
    const refl_image_vec3 cv{color.data(), dn, dw, dh, dw};
    const refl_cluster_finalize_input fp{{kInf, none}, {1, kMax}, false, {1, 0.0f, 0.0f}, false, 0, false};
    std::vector<refl_cluster_shade> shades(pc);
    uint32_t fell = 0;
    CHECK_STATUS(refl_cluster_finalize(&fell, shades.data(), pc, pv, nv, px, pc, eye, &cam, &di, cv, &fp),
                 REFL_STATUS_OK);
    for (const refl_cluster_shade& s : shades) CHECK(s.rays == 1 && s.steps == 1 && s.fetches == 1);
    std::vector<refl_cluster_shade> sbuf(pc);
    uint32_t fbuf = 0;
    const Region sr{sbuf.data(), pc * sizeof(refl_cluster_shade)}, fr{&fbuf, 4};
    auto fin = [&](const char* what, refl_status want, size_t out_len, refl_vec3 e, const refl_cluster_camera* c,
                   const refl_depth_image* d, refl_image_vec3 col, const refl_cluster_finalize_input* p) {
        intact(what, want, {sr, fr},
               [&] { return refl_cluster_finalize(&fbuf, sbuf.data(), out_len, pv, nv, px, pc, e, c, d, col, p); });
    };
    fin("finalize short out", REFL_STATUS_INSUFFICIENT_SIZE, pc - 1, eye, &cam, &di, cv, &fp);
    for (const refl_vec3& b : kBadVec3) fin("finalize eye", REFL_STATUS_INVALID_ARGUMENT, pc, b, &cam, &di, cv, &fp);
    fin("finalize NULL camera", REFL_STATUS_NULL_POINTER, pc, eye, nullptr, &di, cv, &fp);
    fin("finalize NULL depth", REFL_STATUS_NULL_POINTER, pc, eye, &cam, nullptr, cv, &fp);
    fin("finalize NULL params", REFL_STATUS_NULL_POINTER, pc, eye, &cam, &di, cv, nullptr);
    fin("finalize fallback record", REFL_STATUS_INVALID_ARGUMENT, pc, eye, &one, &di, cv, &fp);
    refl_cluster_camera bc = cam;
    bc.normal = v3(kNaN, 1, 0);
    fin("finalize NaN camera normal", REFL_STATUS_INVALID_ARGUMENT, pc, eye, &bc, &di, cv, &fp);
    bc = cam;
    bc.far_distance = -1.0f;
    fin("finalize negative far", REFL_STATUS_INVALID_ARGUMENT, pc, eye, &bc, &di, cv, &fp);
    for (const BadCamera& b : bad_cameras()) {
        bc = cam;
        bc.camera = b.cam;
        fin(b.name, b.status, pc, eye, &bc, &di, cv, &fp);
    }
    for (uint32_t c : kBadConventions) {
        refl_depth_image bd = di;
        bd.convention = c;
        fin("finalize convention", REFL_STATUS_INVALID_ARGUMENT, pc, eye, &cam, &bd, cv, &fp);
    }
    fin("finalize color size", REFL_STATUS_INVALID_ARGUMENT, pc, eye, &cam, &di, {color.data(), dn, dw, 1, dw}, &fp);
    fin("finalize short color", REFL_STATUS_INSUFFICIENT_SIZE, pc, eye, &cam, &di, {color.data(), dn - 1, dw, dh, dw},
        &fp);
    fin("finalize NULL color", REFL_STATUS_NULL_POINTER, pc, eye, &cam, &di, {nullptr, dn, dw, dh, dw}, &fp);
    for (int k = 0; k < 6; ++k) {
        refl_cluster_finalize_input b = fp;
        if (k == 0) b.lobe.rays = 0;
        if (k == 1) b.lobe = {65, 1.0f, 0.5f};
        if (k == 2) b.lobe = {8, kNaN, 0.5f};
        if (k == 3) b.lobe = {8, 10.0f, 2.0f};
        if (k == 4) b.step.stride = 0;
        if (k == 5) b.thickness.constant = kNaN;
        fin("finalize params", REFL_STATUS_INVALID_ARGUMENT, pc, eye, &cam, &di, cv, &b);
    }
    CHECK_STATUS(refl_cluster_finalize(nullptr, sbuf.data(), pc, pv, nv, px, pc, eye, &cam, &di, cv, &fp),
                 REFL_STATUS_NULL_POINTER);
    intact("finalize NULL out", REFL_STATUS_NULL_POINTER, {fr},
           [&] { return refl_cluster_finalize(&fbuf, nullptr, pc, pv, nv, px, pc, eye, &cam, &di, cv, &fp); });
}

// Glossy cone tracing (seed 004 Sec. 4.4.2-4.4.5, 4.6.1, 4.6.8) and the
// multi-ray alternative (seed 003 Sec. 3.5): angles, pyramid sizes and
// builds, cone trace, fades, multi-ray.
void cone_functions() {
    const refl_camera g = good_camera();
    const uint32_t w = g.width, h = g.height;
    const size_t n = size_t(w) * h;

    expect<float>("cone angle phong NaN", REFL_STATUS_INVALID_ARGUMENT,
                  [](float* o) { return refl_cone_angle_from_phong(o, kNaN); });
    expect<float>("cone angle phong -1", REFL_STATUS_INVALID_ARGUMENT,
                  [](float* o) { return refl_cone_angle_from_phong(o, -1.0f); });
    CHECK(expect_ok<float>("cone angle phong", [](float* o) { return refl_cone_angle_from_phong(o, kInf); }) == 0.0f);
    for (float r : {kNaN, -0.1f, 1.5f, kInf})
        expect<float>("cone angle roughness", REFL_STATUS_INVALID_ARGUMENT,
                      [=](float* o) { return refl_cone_angle_from_roughness(o, r); });
    CHECK(expect_ok<float>("cone angle roughness", [](float* o) { return refl_cone_angle_from_roughness(o, 0.5f); }) > 0.0f);

    expect<size_t>("cone pyramid len zero", REFL_STATUS_INVALID_ARGUMENT,
                   [=](size_t* o) { size_t v = 0; return refl_cone_pyramid_len(o, &v, 0, h); });
    expect<size_t>("cone pyramid len overflow", REFL_STATUS_INVALID_ARGUMENT,
                   [](size_t* o) { size_t v = 0; return refl_cone_pyramid_len(o, &v, kMax, kMax); });
    expect<size_t>("cone pyramid vis len zero", REFL_STATUS_INVALID_ARGUMENT,
                   [=](size_t* o) { size_t c = 0; return refl_cone_pyramid_len(&c, o, 0, h); });
    const size_t len = expect_ok<size_t>("cone pyramid len", [=](size_t* o) { size_t v = 0; return refl_cone_pyramid_len(o, &v, w, h); });
    const size_t vlen = expect_ok<size_t>("cone pyramid vis len", [=](size_t* o) { size_t c = 0; return refl_cone_pyramid_len(&c, o, w, h); });
    CHECK(len > n);
    // The same levels, then each pyramid's stamp.
    CHECK(vlen == len - REFL_CONE_COLOR_STAMP_TEXELS + REFL_CONE_VISIBILITY_STAMP_LEN);

    // Hi-Z of a flat depth image for the visibility build and traces.
    std::vector<float> depth(n, 0.5f);
    const refl_depth_image dimg{{depth.data(), n, w, h, w}, g, REFL_DEPTH_CONVENTION_ZERO_TO_ONE};
    // The Hi-Z pyramid is the cone pyramids' layout plus its stamp.
    size_t hiz_len = 0;
    uint32_t hiz_levels = 0;
    CHECK_STATUS(refl_hiz_len(&hiz_len, &hiz_levels, w, h), REFL_STATUS_OK);
    CHECK(hiz_len == len - REFL_CONE_COLOR_STAMP_TEXELS + REFL_HIZ_STAMP_TEXELS);
    std::vector<refl_vec2> hz(hiz_len);
    CHECK_STATUS(refl_hiz_build(hz.data(), hiz_len, &dimg), REFL_STATUS_OK);
    const refl_hiz hiz{hz.data(), hiz_len, g, REFL_DEPTH_CONVENTION_ZERO_TO_ONE};

    // Color pyramid builds: failures leave the destination untouched.
    std::vector<refl_vec3> frame(n, v3(0.25f, 0.5f, 0.75f));
    const refl_image_vec3 img{frame.data(), n, w, h, w};
    auto color_build = [&](const char* what, refl_status want, auto call) {
        std::vector<refl_vec3> dst(len, v3(-7, -7, -7));
        CHECK_STATUS(call(dst.data()), want);
        bool same = true;
        for (const refl_vec3& t : dst) same = same && t.x == -7.0f && t.y == -7.0f && t.z == -7.0f;
        if (want != REFL_STATUS_OK && !same) check::fail(__FILE__, __LINE__, std::string(what) + ": written");
    };
    color_build("cone color ok", REFL_STATUS_OK, [&](refl_vec3* d) { return refl_cone_build_color(d, len, &img, 1.0f); });
    color_build("cone color NULL dst", REFL_STATUS_NULL_POINTER, [&](refl_vec3*) { return refl_cone_build_color(nullptr, len, &img, 1.0f); });
    color_build("cone color NULL image", REFL_STATUS_NULL_POINTER, [&](refl_vec3* d) { return refl_cone_build_color(d, len, nullptr, 1.0f); });
    color_build("cone color short", REFL_STATUS_INSUFFICIENT_SIZE, [&](refl_vec3* d) { return refl_cone_build_color(d, len - 1, &img, 1.0f); });
    for (float sg : {kNaN, 0.0f, -1.0f, kInf})
        color_build("cone color sigma", REFL_STATUS_INVALID_ARGUMENT, [&](refl_vec3* d) { return refl_cone_build_color(d, len, &img, sg); });
    const refl_image_vec3 short_img{frame.data(), n - 1, w, h, w};
    color_build("cone color short image", REFL_STATUS_INSUFFICIENT_SIZE, [&](refl_vec3* d) { return refl_cone_build_color(d, len, &short_img, 1.0f); });
    std::vector<refl_vec3> nan_frame = frame;
    nan_frame[n / 2] = v3(kNaN, 0, 0);
    const refl_image_vec3 nan_img{nan_frame.data(), n, w, h, w};
    color_build("cone color NaN texel", REFL_STATUS_INVALID_ARGUMENT, [&](refl_vec3* d) { return refl_cone_build_color(d, len, &nan_img, 1.0f); });
    color_build("cone color rows ok", REFL_STATUS_OK, [&](refl_vec3* d) { return refl_cone_build_color_rows(d, len, &img, 0, refl_row_range{0, h}, 1.0f); });
    color_build("cone color rows NULL", REFL_STATUS_NULL_POINTER, [&](refl_vec3* d) { return refl_cone_build_color_rows(d, len, nullptr, 0, refl_row_range{0, h}, 1.0f); });
    color_build("cone color rows short", REFL_STATUS_INSUFFICIENT_SIZE, [&](refl_vec3* d) { return refl_cone_build_color_rows(d, len - 1, &img, 1, refl_row_range{0, 1}, 1.0f); });
    color_build("cone color rows level", REFL_STATUS_INVALID_ARGUMENT, [&](refl_vec3* d) { return refl_cone_build_color_rows(d, len, &img, 99, refl_row_range{0, 1}, 1.0f); });
    color_build("cone color rows reversed", REFL_STATUS_INVALID_ARGUMENT, [&](refl_vec3* d) { return refl_cone_build_color_rows(d, len, &img, 0, refl_row_range{3, 2}, 1.0f); });
    color_build("cone color rows NaN sigma", REFL_STATUS_INVALID_ARGUMENT, [&](refl_vec3* d) { return refl_cone_build_color_rows(d, len, &img, 1, refl_row_range{0, 1}, kNaN); });

    // Visibility pyramid builds.
    auto vis_build = [&](const char* what, refl_status want, auto call) {
        std::vector<float> dst(vlen, -7.0f);
        CHECK_STATUS(call(dst.data()), want);
        bool same = true;
        for (float t : dst) same = same && t == -7.0f;
        if (want != REFL_STATUS_OK && !same) check::fail(__FILE__, __LINE__, std::string(what) + ": written");
    };
    vis_build("cone vis ok", REFL_STATUS_OK, [&](float* d) { return refl_cone_build_visibility(d, vlen, &hiz); });
    vis_build("cone vis NULL dst", REFL_STATUS_NULL_POINTER, [&](float*) { return refl_cone_build_visibility(nullptr, vlen, &hiz); });
    vis_build("cone vis NULL hiz", REFL_STATUS_NULL_POINTER, [&](float* d) { return refl_cone_build_visibility(d, vlen, nullptr); });
    vis_build("cone vis short", REFL_STATUS_INSUFFICIENT_SIZE, [&](float* d) { return refl_cone_build_visibility(d, vlen - 1, &hiz); });
    const refl_hiz short_hiz{hz.data(), hiz_len - 1, g, REFL_DEPTH_CONVENTION_ZERO_TO_ONE};
    vis_build("cone vis short hiz", REFL_STATUS_INSUFFICIENT_SIZE, [&](float* d) { return refl_cone_build_visibility(d, vlen, &short_hiz); });
    for (uint32_t c : kBadConventions) {
        const refl_hiz bad{hz.data(), hiz_len, g, c};
        vis_build("cone vis convention", REFL_STATUS_INVALID_ARGUMENT, [&](float* d) { return refl_cone_build_visibility(d, vlen, &bad); });
    }
    vis_build("cone vis rows ok", REFL_STATUS_OK, [&](float* d) { return refl_cone_build_visibility_rows(d, vlen, &hiz, 0, refl_row_range{0, h}); });
    vis_build("cone vis rows NULL", REFL_STATUS_NULL_POINTER, [&](float* d) { return refl_cone_build_visibility_rows(d, vlen, nullptr, 0, refl_row_range{0, h}); });
    vis_build("cone vis rows short", REFL_STATUS_INSUFFICIENT_SIZE, [&](float* d) { return refl_cone_build_visibility_rows(d, vlen - 1, &hiz, 1, refl_row_range{0, 1}); });
    vis_build("cone vis rows level", REFL_STATUS_INVALID_ARGUMENT, [&](float* d) { return refl_cone_build_visibility_rows(d, vlen, &hiz, 99, refl_row_range{0, 1}); });

    // Cone trace.
    std::vector<refl_vec3> color(len);
    std::vector<float> vis(vlen);
    CHECK_STATUS(refl_cone_build_color(color.data(), len, &img, 1.0f), REFL_STATUS_OK);
    CHECK_STATUS(refl_cone_build_visibility(vis.data(), vlen, &hiz), REFL_STATUS_OK);
    const refl_cone_pyramids pyr{hiz, color.data(), len, vis.data(), vlen};
    const refl_cone_options opts = refl_cone_options_default();
    CHECK(opts.max_circles == 8 && opts.use_visibility && opts.max_stretch == 1.0f);
    const refl_cone cone{v2(10, 40), 2.0f, v2(30, 10), 3.0f, 0.2f, 0.8f, 4.0f};
    const refl_vec3 fb = v3(0.1f, 0.2f, 0.3f);
    const refl_cone_result r = expect_ok<refl_cone_result>(
        "cone trace", [&](refl_cone_result* o) { return refl_cone_trace(o, &pyr, &cone, fb, &opts); });
    CHECK(r.coverage >= 0.0f && r.coverage <= 1.0f && r.circles > 0);
    auto trace = [&](const char* what, refl_status want, const refl_cone_pyramids* p, const refl_cone* c, refl_vec3 f,
                     const refl_cone_options* o) {
        expect<refl_cone_result>(what, want, [=](refl_cone_result* out) { return refl_cone_trace(out, p, c, f, o); });
    };
    trace("cone trace NULL pyramids", REFL_STATUS_NULL_POINTER, nullptr, &cone, fb, &opts);
    trace("cone trace NULL cone", REFL_STATUS_NULL_POINTER, &pyr, nullptr, fb, &opts);
    trace("cone trace NULL options", REFL_STATUS_NULL_POINTER, &pyr, &cone, fb, nullptr);
    const refl_cone_pyramids null_color{hiz, nullptr, len, vis.data(), vlen};
    trace("cone trace NULL color", REFL_STATUS_NULL_POINTER, &null_color, &cone, fb, &opts);
    const refl_cone_pyramids short_color{hiz, color.data(), len - 1, vis.data(), vlen};
    trace("cone trace short color", REFL_STATUS_INSUFFICIENT_SIZE, &short_color, &cone, fb, &opts);
    const refl_cone_pyramids short_vis{hiz, color.data(), len, vis.data(), 3};
    trace("cone trace short visibility", REFL_STATUS_INSUFFICIENT_SIZE, &short_vis, &cone, fb, &opts);
    {
        // An unbuilt visibility pyramid, and none at all.
        std::vector<float> blank(vlen, 0.0f);
        const refl_cone_pyramids no_stamp{hiz, color.data(), len, blank.data(), vlen};
        trace("cone trace unbuilt visibility", REFL_STATUS_INVALID_ARGUMENT, &no_stamp, &cone, fb, &opts);
        refl_cone_result cr{};
        CHECK_STATUS(refl_cone_trace(&cr, &no_stamp, &cone, fb, &opts), REFL_STATUS_INVALID_ARGUMENT);
        char msg[256];
        refl_last_error_message(msg, sizeof msg);
        CHECK(std::strstr(msg, "`pyramids.visibility`") != nullptr);
        const refl_cone_pyramids no_vis{hiz, color.data(), len, nullptr, 0};
        trace("cone trace no visibility, use_visibility on", REFL_STATUS_INVALID_ARGUMENT, &no_vis, &cone, fb, &opts);
        refl_cone_options off = opts;
        off.use_visibility = 0;
        expect_ok<refl_cone_result>("cone trace no visibility, use_visibility off",
                                    [&](refl_cone_result* o) { return refl_cone_trace(o, &no_vis, &cone, fb, &off); });
    }
    for (const refl_vec3& bad : kBadVec3) trace("cone trace bad fallback", REFL_STATUS_INVALID_ARGUMENT, &pyr, &cone, bad, &opts);
    for (const refl_vec2& bad : kBadVec2) {
        refl_cone c = cone;
        c.apex = bad;
        trace("cone trace bad apex", REFL_STATUS_INVALID_ARGUMENT, &pyr, &c, fb, &opts);
        c = cone;
        c.hit = bad;
        trace("cone trace bad hit", REFL_STATUS_INVALID_ARGUMENT, &pyr, &c, fb, &opts);
    }
    for (float t : {kNaN, -0.1f, 1.5708f, kInf}) {
        refl_cone c = cone;
        c.theta = t;
        trace("cone trace bad theta", REFL_STATUS_INVALID_ARGUMENT, &pyr, &c, fb, &opts);
    }
    for (float d : {kNaN, 0.0f, -1.0f, kInf}) {
        refl_cone c = cone;
        c.hit_depth = d;
        trace("cone trace bad depth", REFL_STATUS_INVALID_ARGUMENT, &pyr, &c, fb, &opts);
    }
    for (float t : {kNaN, -1.0f, kInf}) {
        refl_cone c = cone;
        c.travel = t;
        trace("cone trace bad travel", REFL_STATUS_INVALID_ARGUMENT, &pyr, &c, fb, &opts);
    }
    {
        refl_cone_options o = opts;
        o.max_stretch = 0.5f;
        trace("cone trace bad stretch", REFL_STATUS_INVALID_ARGUMENT, &pyr, &cone, fb, &o);
        o = opts;
        o.level_bias = kNaN;
        trace("cone trace bad bias", REFL_STATUS_INVALID_ARGUMENT, &pyr, &cone, fb, &o);
        o = opts;
        o.depth_tolerance = -1.0f;
        trace("cone trace bad tolerance", REFL_STATUS_INVALID_ARGUMENT, &pyr, &cone, fb, &o);
    }
    for (const BadCamera& bc : bad_cameras()) {
        refl_cone_pyramids p = pyr;
        p.hiz.camera = bc.cam;
        trace(bc.name, bc.status, &p, &cone, fb, &opts);
    }

    // Fades.
    const refl_cone_fades fades{{true, 0.0f, 0.5f}, {true, 0.8f, 1.0f}, {true, 2.0f, 6.0f}};
    CHECK(expect_ok<float>("cone fade", [&](float* o) {
              return refl_cone_fade(o, &fades, v3(1, 0, 0), v3(0, 0, 1), v2(32, 24), w, h, 1.0f);
          }) == 1.0f);
    auto fade = [&](const char* what, refl_status want, const refl_cone_fades* f, refl_vec3 r3, refl_vec2 hp, uint32_t fw,
                    float t) {
        expect<float>(what, want, [=](float* o) { return refl_cone_fade(o, f, r3, v3(0, 0, 1), hp, fw, h, t); });
    };
    fade("cone fade NULL", REFL_STATUS_NULL_POINTER, nullptr, v3(1, 0, 0), v2(1, 1), w, 1.0f);
    for (const refl_vec3& bad : kBadVec3) fade("cone fade bad dir", REFL_STATUS_INVALID_ARGUMENT, &fades, bad, v2(1, 1), w, 1.0f);
    for (const refl_vec2& bad : kBadVec2) fade("cone fade bad hit", REFL_STATUS_INVALID_ARGUMENT, &fades, v3(1, 0, 0), bad, w, 1.0f);
    fade("cone fade zero width", REFL_STATUS_INVALID_ARGUMENT, &fades, v3(1, 0, 0), v2(1, 1), 0, 1.0f);
    fade("cone fade NaN t", REFL_STATUS_INVALID_ARGUMENT, &fades, v3(1, 0, 0), v2(1, 1), w, kNaN);
    {
        refl_cone_fades f = fades;
        f.border = {true, 1.0f, 1.0f};
        fade("cone fade empty range", REFL_STATUS_INVALID_ARGUMENT, &f, v3(1, 0, 0), v2(1, 1), w, 1.0f);
        f = fades;
        f.travel = {true, kNaN, 1.0f};
        fade("cone fade NaN range", REFL_STATUS_INVALID_ARGUMENT, &f, v3(1, 0, 0), v2(1, 1), w, 1.0f);
        // A disabled range is not read, however bad.
        f.travel.enabled = false;
        CHECK(expect_ok<float>("cone fade disabled NaN range", [&](float* o) {
                  return refl_cone_fade(o, &f, v3(1, 0, 0), v3(0, 0, 1), v2(32, 24), w, h, 1.0f);
              }) == 1.0f);
    }

    // Multi-ray.
    const refl_image_f32 none{nullptr, 0, 0, 0, 0};
    const refl_trace_thickness thick{0.5f, none};
    refl_cone_multiray_options mo = refl_cone_multiray_options_default();
    mo.rotation = v2(0.25f, 0.5f);
    mo.hiz.max_iterations = 256;
    const refl_ray ray{v3(1, 1, 3), v3(0, 0, -1)};
    const refl_cone_multiray_result mr = expect_ok<refl_cone_multiray_result>("cone multiray", [&](refl_cone_multiray_result* o) {
        return refl_cone_multiray(o, &pyr, &thick, ray, v3(0, 1, 0), kInf, 0.2f, 20.0f, &mo, fb);
    });
    CHECK(mr.traced <= 8);
    auto multi = [&](const char* what, refl_status want, const refl_cone_pyramids* p, const refl_trace_thickness* tk,
                     refl_ray ry, refl_vec3 nrm, float t_max, float theta, float power,
                     const refl_cone_multiray_options* o, refl_vec3 f) {
        expect<refl_cone_multiray_result>(what, want, [=](refl_cone_multiray_result* out) {
            return refl_cone_multiray(out, p, tk, ry, nrm, t_max, theta, power, o, f);
        });
    };
    const refl_vec3 up = v3(0, 1, 0);
    multi("cone multiray NULL pyramids", REFL_STATUS_NULL_POINTER, nullptr, &thick, ray, up, kInf, 0.2f, 20.0f, &mo, fb);
    multi("cone multiray NULL thickness", REFL_STATUS_NULL_POINTER, &pyr, nullptr, ray, up, kInf, 0.2f, 20.0f, &mo, fb);
    multi("cone multiray NULL options", REFL_STATUS_NULL_POINTER, &pyr, &thick, ray, up, kInf, 0.2f, 20.0f, nullptr, fb);
    multi("cone multiray short color", REFL_STATUS_INSUFFICIENT_SIZE, &short_color, &thick, ray, up, kInf, 0.2f, 20.0f, &mo, fb);
    for (const refl_vec3& bad : kBadVec3) {
        multi("cone multiray bad normal", REFL_STATUS_INVALID_ARGUMENT, &pyr, &thick, ray, bad, kInf, 0.2f, 20.0f, &mo, fb);
        multi("cone multiray bad fallback", REFL_STATUS_INVALID_ARGUMENT, &pyr, &thick, ray, up, kInf, 0.2f, 20.0f, &mo, bad);
        multi("cone multiray bad origin", REFL_STATUS_INVALID_ARGUMENT, &pyr, &thick, {bad, ray.dir}, up, kInf, 0.2f, 20.0f, &mo, fb);
    }
    for (float t : {kNaN, -0.1f, 2.0f})
        multi("cone multiray bad theta", REFL_STATUS_INVALID_ARGUMENT, &pyr, &thick, ray, up, kInf, t, 20.0f, &mo, fb);
    for (float p : {kNaN, -1.0f})
        multi("cone multiray bad power", REFL_STATUS_INVALID_ARGUMENT, &pyr, &thick, ray, up, kInf, 0.2f, p, &mo, fb);
    multi("cone multiray NaN t_max", REFL_STATUS_INVALID_ARGUMENT, &pyr, &thick, ray, up, kNaN, 0.2f, 20.0f, &mo, fb);
    {
        refl_cone_multiray_options o = mo;
        o.rays = 0;
        multi("cone multiray zero rays", REFL_STATUS_INVALID_ARGUMENT, &pyr, &thick, ray, up, kInf, 0.2f, 20.0f, &o, fb);
        o = mo;
        o.rotation = v2(kNaN, 0);
        multi("cone multiray NaN rotation", REFL_STATUS_INVALID_ARGUMENT, &pyr, &thick, ray, up, kInf, 0.2f, 20.0f, &o, fb);
    }
    const refl_trace_thickness nan_thick{kNaN, none};
    multi("cone multiray NaN thickness", REFL_STATUS_INVALID_ARGUMENT, &pyr, &nan_thick, ray, up, kInf, 0.2f, 20.0f, &mo, fb);
}

// The screen-space mirror pass: scratch size, prepare and trace with NULL
// pointers, unknown enums, options out of range, short and aliased
// buffers, rows out of range and pyramids of another camera. Every output
// (stats, texels, colors, host rays, scratch) must be left untouched.
void ssr_functions() {
    const refl_camera g = good_camera();
    const uint32_t w = g.width, h = g.height;
    const size_t n = size_t(w) * h;
    std::vector<float> depth(n, 0.5f);
    std::vector<refl_vec3> normals(n, v3(0, 1, 0)), color(n, v3(0.5f, 0.5f, 0.5f));
    const refl_image_f32 none{nullptr, 0, 0, 0, 0};
    refl_gbuffer gb{};
    gb.depth = {{depth.data(), n, w, h, w}, g, REFL_DEPTH_CONVENTION_ZERO_TO_ONE};
    gb.normals = {normals.data(), n, w, h, w};
    gb.normal_space = REFL_NORMAL_SPACE_WORLD;
    gb.mask = {nullptr, 0, 0, 0, 0};
    gb.roughness = none;
    gb.color = {color.data(), n, w, h, w};
    gb.back_depth = none;
    const refl_ssr_options def = refl_ssr_options_default();
    refl_ssr_options hz = def;
    hz.method = REFL_SSR_METHOD_HIZ;

    // Scratch size.
    const size_t zero = expect_ok<size_t>("ssr scratch step", [&](size_t* o) { return refl_ssr_scratch_len(o, &gb, &def); });
    CHECK_EQ(zero, size_t(0));
    const size_t len = expect_ok<size_t>("ssr scratch hiz", [&](size_t* o) { return refl_ssr_scratch_len(o, &gb, &hz); });
    CHECK(len > n);
    expect<size_t>("ssr scratch NULL gbuffer", REFL_STATUS_NULL_POINTER,
                   [&](size_t* o) { return refl_ssr_scratch_len(o, nullptr, &def); });
    expect<size_t>("ssr scratch NULL options", REFL_STATUS_NULL_POINTER,
                   [&](size_t* o) { return refl_ssr_scratch_len(o, &gb, nullptr); });
    for (uint32_t m : {2u, 7u, kMax}) {
        refl_ssr_options o = def;
        o.method = m;
        expect<size_t>("ssr scratch bad method", REFL_STATUS_INVALID_ARGUMENT,
                       [&](size_t* out) { return refl_ssr_scratch_len(out, &gb, &o); });
    }
    for (const BadCamera& bc : bad_cameras()) {
        refl_gbuffer b = gb;
        b.depth.camera = bc.cam;
        expect<size_t>(bc.name, bc.status, [&](size_t* o) { return refl_ssr_scratch_len(o, &b, &def); });
    }

    // Prepare: the scratch is its output.
    auto prep = [&](const char* what, refl_status want, size_t scratch_len, const refl_gbuffer* gbp,
                    const refl_ssr_options* o, bool null_scratch = false) {
        std::vector<refl_vec2> scratch(len + 4, v2(-7.0f, -7.0f));
        const uint32_t got = refl_ssr_prepare(null_scratch ? nullptr : scratch.data(), scratch_len, gbp, o);
        ++check::checks();
        bool untouched = true;
        for (const refl_vec2& v : scratch) untouched = untouched && v.x == -7.0f && v.y == -7.0f;
        if (got != static_cast<uint32_t>(want) || !untouched)
            check::fail(__FILE__, __LINE__, std::string(what) + ": got " + check::status_name(got));
    };
    prep("ssr prepare NULL gbuffer", REFL_STATUS_NULL_POINTER, len, nullptr, &hz);
    prep("ssr prepare NULL options", REFL_STATUS_NULL_POINTER, len, &gb, nullptr);
    prep("ssr prepare NULL scratch", REFL_STATUS_NULL_POINTER, len, &gb, &hz, true);
    prep("ssr prepare short scratch", REFL_STATUS_INSUFFICIENT_SIZE, len - 1, &gb, &hz);
    {
        refl_gbuffer b = gb;
        b.normal_space = 2;
        prep("ssr prepare bad normal space", REFL_STATUS_INVALID_ARGUMENT, len, &b, &hz);
        b = gb;
        b.depth.convention = 3;
        prep("ssr prepare bad convention", REFL_STATUS_INVALID_ARGUMENT, len, &b, &hz);
        b = gb;
        b.normals.data = nullptr;
        prep("ssr prepare NULL normals", REFL_STATUS_NULL_POINTER, len, &b, &hz);
        b = gb;
        b.normals.len = n - 1;
        prep("ssr prepare short normals", REFL_STATUS_INSUFFICIENT_SIZE, len, &b, &hz);
        b = gb;
        b.color.width = w - 1;
        prep("ssr prepare color of another size", REFL_STATUS_INVALID_ARGUMENT, len, &b, &hz);
        b = gb;
        b.back_depth = {depth.data(), n, w, h - 1, w};
        prep("ssr prepare back depth of another size", REFL_STATUS_INVALID_ARGUMENT, len, &b, &hz);
    }
    for (float bad : {kNaN, -1.0f, kInf}) {
        refl_ssr_options o = hz;
        o.thickness = bad;
        prep("ssr prepare bad thickness", REFL_STATUS_INVALID_ARGUMENT, len, &gb, &o);
        o = hz;
        o.start_pixels = bad;
        prep("ssr prepare bad start", REFL_STATUS_INVALID_ARGUMENT, len, &gb, &o);
        o = hz;
        o.border_fade = bad;
        prep("ssr prepare bad fade", REFL_STATUS_INVALID_ARGUMENT, len, &gb, &o);
    }

    // Trace: every output prefilled.
    std::vector<refl_vec2> pyr(len);
    CHECK_STATUS(refl_ssr_prepare(pyr.data(), len, &gb, &hz), REFL_STATUS_OK);
    const refl_row_range all{0, h};
    auto trace = [&](const char* what, refl_status want, const refl_gbuffer* gbp, const refl_ssr_options* o,
                     const refl_vec2* scratch, size_t scratch_len, refl_row_range rows, size_t out_len,
                     bool with_color, bool null_out = false, size_t host_len = 16, bool null_host = false) {
        std::vector<refl_ssr_texel> out(n + 1);
        std::memset(static_cast<void*>(out.data()), 0x5A, out.size() * sizeof(refl_ssr_texel));
        std::vector<refl_vec3> col(n, v3(-3, -3, -3));
        std::vector<refl_host_ray> host(16);
        std::memset(static_cast<void*>(host.data()), 0x6B, host.size() * sizeof(refl_host_ray));
        const refl_image_vec3_mut cm = with_color ? refl_image_vec3_mut{col.data(), n, w, h, w}
                                                  : refl_image_vec3_mut{nullptr, 0, 0, 0, 0};
        expect<refl_ssr_stats>(what, want, [&](refl_ssr_stats* st) {
            return refl_ssr_trace_rows(st, null_out ? nullptr : out.data(), out_len, cm,
                                       null_host ? nullptr : host.data(), host_len, gbp, o, scratch,
                                       scratch_len, rows);
        }, false);
        bool untouched = true;
        const unsigned char* ob = reinterpret_cast<const unsigned char*>(out.data());
        for (size_t i = 0; i < out.size() * sizeof(refl_ssr_texel); ++i) untouched = untouched && ob[i] == 0x5A;
        const unsigned char* hb = reinterpret_cast<const unsigned char*>(host.data());
        for (size_t i = 0; i < host.size() * sizeof(refl_host_ray); ++i) untouched = untouched && hb[i] == 0x6B;
        for (const refl_vec3& c : col) untouched = untouched && c.x == -3.0f;
        CHECK(untouched);
    };
    const refl_ssr_stats ok = expect_ok<refl_ssr_stats>("ssr trace", [&](refl_ssr_stats* st) {
        std::vector<refl_ssr_texel> out(n);
        std::vector<refl_host_ray> host(n);
        std::vector<refl_vec3> col(n);
        return refl_ssr_trace_rows(st, out.data(), n, {col.data(), n, w, h, w}, host.data(), n, &gb, &hz,
                                   pyr.data(), len, all);
    });
    CHECK(ok.traced == n);
    CHECK_STATUS(refl_ssr_trace_rows(nullptr, nullptr, n, {nullptr, 0, 0, 0, 0}, nullptr, 0, &gb, &def, nullptr,
                                     0, all),
                 REFL_STATUS_NULL_POINTER);
    trace("ssr trace NULL out", REFL_STATUS_NULL_POINTER, &gb, &def, nullptr, 0, all, n, true, true);
    trace("ssr trace NULL gbuffer", REFL_STATUS_NULL_POINTER, nullptr, &def, nullptr, 0, all, n, true);
    trace("ssr trace NULL options", REFL_STATUS_NULL_POINTER, &gb, nullptr, nullptr, 0, all, n, true);
    trace("ssr trace NULL host", REFL_STATUS_NULL_POINTER, &gb, &def, nullptr, 0, all, n, true, false, 16, true);
    trace("ssr trace short out", REFL_STATUS_INSUFFICIENT_SIZE, &gb, &def, nullptr, 0, all, n - 1, true);
    trace("ssr trace reversed rows", REFL_STATUS_INVALID_ARGUMENT, &gb, &def, nullptr, 0, {3, 2}, n, true);
    trace("ssr trace rows past the end", REFL_STATUS_INVALID_ARGUMENT, &gb, &def, nullptr, 0, {0, h + 1}, n, true);
    trace("ssr trace NULL pyramid", REFL_STATUS_NULL_POINTER, &gb, &hz, nullptr, 0, all, n, true);
    trace("ssr trace short pyramid", REFL_STATUS_INSUFFICIENT_SIZE, &gb, &hz, pyr.data(), len - 1, all, n, true);
    {
        std::vector<refl_vec2> blank(len, v2(0, 0));
        trace("ssr trace unprepared pyramid", REFL_STATUS_INVALID_ARGUMENT, &gb, &hz, blank.data(), len, all, n, true);
        refl_gbuffer other = gb;
        REQUIRE(refl_camera_look_at(&other.depth.camera, v3(1, 2, 6), v3(0, 0.5f, 0), v3(0, 1, 0), 1.0f, 0.1f,
                                    100.0f, 64, 48) == REFL_STATUS_OK);
        trace("ssr trace pyramid of another camera", REFL_STATUS_INVALID_ARGUMENT, &other, &hz, pyr.data(), len,
              all, n, true);
        refl_gbuffer nocolor = gb;
        nocolor.color = {nullptr, 0, 0, 0, 0};
        trace("ssr trace color without a G-buffer color", REFL_STATUS_INVALID_ARGUMENT, &nocolor, &def, nullptr, 0,
              all, n, true);
    }
    {
        // Misaligned texels; texels aliasing the G-buffer's normals.
        std::vector<refl_ssr_texel> out(n + 1);
        refl_ssr_stats st{};
        CHECK_STATUS(refl_ssr_trace_rows(&st, reinterpret_cast<refl_ssr_texel*>(reinterpret_cast<char*>(out.data()) + 1),
                                         n, {nullptr, 0, 0, 0, 0}, nullptr, 0, &gb, &def, nullptr, 0, all),
                     REFL_STATUS_INVALID_ARGUMENT);
        std::vector<refl_vec3> big(4 * n, v3(0, 1, 0));
        refl_gbuffer alias = gb;
        alias.normals = {big.data(), n, w, h, w};
        CHECK_STATUS(refl_ssr_trace_rows(&st, reinterpret_cast<refl_ssr_texel*>(big.data()), n,
                                         {nullptr, 0, 0, 0, 0}, nullptr, 0, &alias, &def, nullptr, 0, all),
                     REFL_STATUS_INVALID_ARGUMENT);
        CHECK(big[0].y == 1.0f && big[3 * n].y == 1.0f);
    }
}


// The glossy pass: scratch size, prepare and trace with NULL pointers,
// unknown enums, options out of range, G-buffers without color or
// roughness, short, misaligned and aliased buffers, rows out of range and
// pyramids of another camera. Every output (stats, texels, colors, host
// rays, scratch) must be left untouched.
void glossy_functions() {
    const refl_camera g = good_camera();
    const uint32_t w = g.width, h = g.height;
    const size_t n = size_t(w) * h;
    std::vector<float> depth(n, 0.5f), rough(n, 0.3f);
    std::vector<refl_vec3> normals(n, v3(0, 1, 0)), color(n, v3(0.5f, 0.5f, 0.5f));
    const refl_image_f32 none{nullptr, 0, 0, 0, 0};
    refl_gbuffer gb{};
    gb.depth = {{depth.data(), n, w, h, w}, g, REFL_DEPTH_CONVENTION_ZERO_TO_ONE};
    gb.normals = {normals.data(), n, w, h, w};
    gb.normal_space = REFL_NORMAL_SPACE_WORLD;
    gb.mask = {nullptr, 0, 0, 0, 0};
    gb.roughness = {rough.data(), n, w, h, w};
    gb.color = {color.data(), n, w, h, w};
    gb.back_depth = none;
    const refl_glossy_options def = refl_glossy_options_default();
    refl_glossy_options vis = def;
    vis.use_visibility = true;

    // Scratch size.
    const size_t len = expect_ok<size_t>("glossy scratch", [&](size_t* o) { return refl_glossy_scratch_len(o, &gb, &def); });
    const size_t vis_len =
        expect_ok<size_t>("glossy scratch vis", [&](size_t* o) { return refl_glossy_scratch_len(o, &gb, &vis); });
    CHECK(len > 5 * n && vis_len > len);
    expect<size_t>("glossy scratch NULL gbuffer", REFL_STATUS_NULL_POINTER,
                   [&](size_t* o) { return refl_glossy_scratch_len(o, nullptr, &def); });
    expect<size_t>("glossy scratch NULL options", REFL_STATUS_NULL_POINTER,
                   [&](size_t* o) { return refl_glossy_scratch_len(o, &gb, nullptr); });
    for (uint32_t m : {2u, 7u, kMax}) {
        refl_glossy_options o = def;
        o.method = m;
        expect<size_t>("glossy scratch bad method", REFL_STATUS_INVALID_ARGUMENT,
                       [&](size_t* out) { return refl_glossy_scratch_len(out, &gb, &o); });
    }
    for (const BadCamera& bc : bad_cameras()) {
        refl_gbuffer b = gb;
        b.depth.camera = bc.cam;
        expect<size_t>(bc.name, bc.status, [&](size_t* o) { return refl_glossy_scratch_len(o, &b, &def); });
    }

    // Prepare: the scratch is its output.
    auto prep = [&](const char* what, refl_status want, size_t scratch_len, const refl_gbuffer* gbp,
                    const refl_glossy_options* o, bool null_scratch = false, bool misaligned = false) {
        std::vector<float> scratch(vis_len + 4, -7.0f);
        float* p = null_scratch ? nullptr : scratch.data();
        if (misaligned) p = reinterpret_cast<float*>(reinterpret_cast<char*>(scratch.data()) + 1);
        const uint32_t got = refl_glossy_prepare(p, scratch_len, gbp, o);
        ++check::checks();
        bool untouched = true;
        for (size_t i = 0; i + 1 < scratch.size(); ++i) untouched = untouched && scratch[i] == -7.0f;
        if (got != static_cast<uint32_t>(want) || !untouched)
            check::fail(__FILE__, __LINE__, std::string(what) + ": got " + check::status_name(got));
    };
    prep("glossy prepare NULL gbuffer", REFL_STATUS_NULL_POINTER, len, nullptr, &def);
    prep("glossy prepare NULL options", REFL_STATUS_NULL_POINTER, len, &gb, nullptr);
    prep("glossy prepare NULL scratch", REFL_STATUS_NULL_POINTER, len, &gb, &def, true);
    prep("glossy prepare misaligned scratch", REFL_STATUS_INVALID_ARGUMENT, len, &gb, &def, false, true);
    prep("glossy prepare short scratch", REFL_STATUS_INSUFFICIENT_SIZE, len - 1, &gb, &def);
    prep("glossy prepare short scratch for visibility", REFL_STATUS_INSUFFICIENT_SIZE, len, &gb, &vis);
    {
        refl_gbuffer b = gb;
        b.normal_space = 2;
        prep("glossy prepare bad normal space", REFL_STATUS_INVALID_ARGUMENT, len, &b, &def);
        b = gb;
        b.depth.convention = 3;
        prep("glossy prepare bad convention", REFL_STATUS_INVALID_ARGUMENT, len, &b, &def);
        b = gb;
        b.normals.data = nullptr;
        prep("glossy prepare NULL normals", REFL_STATUS_NULL_POINTER, len, &b, &def);
        b = gb;
        b.roughness.len = n - 1;
        prep("glossy prepare short roughness", REFL_STATUS_INSUFFICIENT_SIZE, len, &b, &def);
        b = gb;
        b.roughness = none;
        prep("glossy prepare no roughness", REFL_STATUS_INVALID_ARGUMENT, len, &b, &def);
        b = gb;
        b.color = {nullptr, 0, 0, 0, 0};
        prep("glossy prepare no color", REFL_STATUS_INVALID_ARGUMENT, len, &b, &def);
        b = gb;
        b.color.width = w - 1;
        prep("glossy prepare color of another size", REFL_STATUS_INVALID_ARGUMENT, len, &b, &def);
        std::vector<refl_vec3> hot = color;
        hot[7] = v3(kNaN, 0, 0);
        b = gb;
        b.color.data = hot.data();
        prep("glossy prepare NaN color", REFL_STATUS_INVALID_ARGUMENT, len, &b, &def);
        hot[7] = v3(0, kInf, 0);
        prep("glossy prepare infinite color", REFL_STATUS_INVALID_ARGUMENT, len, &b, &def);
    }
    for (float bad : {kNaN, -1.0f, kInf}) {
        refl_glossy_options o = def;
        o.thickness = bad;
        prep("glossy prepare bad thickness", REFL_STATUS_INVALID_ARGUMENT, len, &gb, &o);
        o = def;
        o.sigma = bad;
        prep("glossy prepare bad sigma", REFL_STATUS_INVALID_ARGUMENT, len, &gb, &o);
        o = def;
        o.max_stretch = bad;
        prep("glossy prepare bad stretch", REFL_STATUS_INVALID_ARGUMENT, len, &gb, &o);
        o = def;
        o.fade_travel = {true, 0.0f, bad};
        prep("glossy prepare bad fade", REFL_STATUS_INVALID_ARGUMENT, len, &gb, &o);
    }
    {
        refl_glossy_options o = def;
        o.rays = 0;
        prep("glossy prepare zero rays", REFL_STATUS_INVALID_ARGUMENT, len, &gb, &o);
        o = def;
        o.min_roughness = kNaN;
        prep("glossy prepare NaN roughness limit", REFL_STATUS_INVALID_ARGUMENT, len, &gb, &o);
        o = def;
        o.method = 9;
        prep("glossy prepare bad method", REFL_STATUS_INVALID_ARGUMENT, len, &gb, &o);
        // A scratch over the depth image it reads.
        std::vector<float> big(len + n, 0.5f);
        refl_gbuffer b = gb;
        b.depth.depth.data = big.data();
        CHECK_STATUS(refl_glossy_prepare(big.data(), len, &b, &def), REFL_STATUS_INVALID_ARGUMENT);
    }

    // Trace: every output prefilled.
    std::vector<float> pyr(len);
    CHECK_STATUS(refl_glossy_prepare(pyr.data(), len, &gb, &def), REFL_STATUS_OK);
    const refl_row_range all{0, h};
    auto trace = [&](const char* what, refl_status want, const refl_gbuffer* gbp, const refl_glossy_options* o,
                     const float* scratch, size_t scratch_len, refl_row_range rows, size_t out_len,
                     bool null_out = false, size_t host_len = 16, bool null_host = false) {
        std::vector<refl_glossy_texel> out(n + 1);
        std::memset(static_cast<void*>(out.data()), 0x5A, out.size() * sizeof(refl_glossy_texel));
        std::vector<refl_vec3> col(n, v3(-3, -3, -3));
        std::vector<refl_host_ray> host(16);
        std::memset(static_cast<void*>(host.data()), 0x6B, host.size() * sizeof(refl_host_ray));
        const refl_image_vec3_mut cm{col.data(), n, w, h, w};
        expect<refl_glossy_stats>(what, want, [&](refl_glossy_stats* st) {
            return refl_glossy_trace_rows(st, null_out ? nullptr : out.data(), out_len, cm,
                                          null_host ? nullptr : host.data(), host_len, gbp, o, scratch, scratch_len,
                                          rows);
        }, false);
        bool untouched = true;
        const unsigned char* ob = reinterpret_cast<const unsigned char*>(out.data());
        for (size_t i = 0; i < out.size() * sizeof(refl_glossy_texel); ++i) untouched = untouched && ob[i] == 0x5A;
        const unsigned char* hb = reinterpret_cast<const unsigned char*>(host.data());
        for (size_t i = 0; i < host.size() * sizeof(refl_host_ray); ++i) untouched = untouched && hb[i] == 0x6B;
        for (const refl_vec3& c : col) untouched = untouched && c.x == -3.0f;
        CHECK(untouched);
    };
    const refl_glossy_stats ok = expect_ok<refl_glossy_stats>("glossy trace", [&](refl_glossy_stats* st) {
        std::vector<refl_glossy_texel> out(n);
        std::vector<refl_host_ray> host(n);
        std::vector<refl_vec3> col(n);
        return refl_glossy_trace_rows(st, out.data(), n, {col.data(), n, w, h, w}, host.data(), n, &gb, &def,
                                      pyr.data(), len, all);
    });
    CHECK(ok.traced == n);
    CHECK_STATUS(refl_glossy_trace_rows(nullptr, nullptr, n, {nullptr, 0, 0, 0, 0}, nullptr, 0, &gb, &def,
                                        pyr.data(), len, all),
                 REFL_STATUS_NULL_POINTER);
    trace("glossy trace NULL out", REFL_STATUS_NULL_POINTER, &gb, &def, pyr.data(), len, all, n, true);
    trace("glossy trace NULL gbuffer", REFL_STATUS_NULL_POINTER, nullptr, &def, pyr.data(), len, all, n);
    trace("glossy trace NULL options", REFL_STATUS_NULL_POINTER, &gb, nullptr, pyr.data(), len, all, n);
    trace("glossy trace NULL host", REFL_STATUS_NULL_POINTER, &gb, &def, pyr.data(), len, all, n, false, 16, true);
    trace("glossy trace NULL scratch", REFL_STATUS_NULL_POINTER, &gb, &def, nullptr, len, all, n);
    trace("glossy trace short out", REFL_STATUS_INSUFFICIENT_SIZE, &gb, &def, pyr.data(), len, all, n - 1);
    trace("glossy trace reversed rows", REFL_STATUS_INVALID_ARGUMENT, &gb, &def, pyr.data(), len, {3, 2}, n);
    trace("glossy trace rows past the end", REFL_STATUS_INVALID_ARGUMENT, &gb, &def, pyr.data(), len, {0, h + 1}, n);
    trace("glossy trace short scratch", REFL_STATUS_INSUFFICIENT_SIZE, &gb, &def, pyr.data(), len - 1, all, n);
    trace("glossy trace misaligned scratch", REFL_STATUS_INVALID_ARGUMENT, &gb, &def,
          reinterpret_cast<const float*>(reinterpret_cast<const char*>(pyr.data()) + 2), len - 1, all, n);
    {
        refl_glossy_options o = def;
        o.method = 5;
        trace("glossy trace bad method", REFL_STATUS_INVALID_ARGUMENT, &gb, &o, pyr.data(), len, all, n);
        o = def;
        o.t_max = -1.0f;
        trace("glossy trace bad t_max", REFL_STATUS_INVALID_ARGUMENT, &gb, &o, pyr.data(), len, all, n);
        std::vector<float> blank(len, 0.0f);
        trace("glossy trace unprepared scratch", REFL_STATUS_INVALID_ARGUMENT, &gb, &def, blank.data(), len, all, n);
        std::vector<float> padded(vis_len, 0.0f);
        std::memcpy(padded.data(), pyr.data(), len * sizeof(float));
        trace("glossy trace without the visibility pyramid", REFL_STATUS_INVALID_ARGUMENT, &gb, &vis,
              padded.data(), vis_len, all, n);
        refl_gbuffer other = gb;
        REQUIRE(refl_camera_look_at(&other.depth.camera, v3(1, 2, 6), v3(0, 0.5f, 0), v3(0, 1, 0), 1.0f, 0.1f,
                                    100.0f, 64, 48) == REFL_STATUS_OK);
        trace("glossy trace scratch of another camera", REFL_STATUS_INVALID_ARGUMENT, &other, &def, pyr.data(), len,
              all, n);
        refl_gbuffer nocolor = gb;
        nocolor.color = {nullptr, 0, 0, 0, 0};
        trace("glossy trace without a G-buffer color", REFL_STATUS_INVALID_ARGUMENT, &nocolor, &def, pyr.data(), len,
              all, n);
    }
    {
        // Misaligned texels; texels aliasing the scratch or the normals.
        std::vector<refl_glossy_texel> out(n + 1);
        refl_glossy_stats st{};
        CHECK_STATUS(refl_glossy_trace_rows(&st,
                                            reinterpret_cast<refl_glossy_texel*>(
                                                reinterpret_cast<char*>(out.data()) + 1),
                                            n, {nullptr, 0, 0, 0, 0}, nullptr, 0, &gb, &def, pyr.data(), len, all),
                     REFL_STATUS_INVALID_ARGUMENT);
        std::vector<float> big(len + 16 * n, 1.0f);
        CHECK_STATUS(refl_glossy_prepare(big.data(), len, &gb, &def), REFL_STATUS_OK);
        CHECK_STATUS(refl_glossy_trace_rows(&st, reinterpret_cast<refl_glossy_texel*>(big.data() + 8), n,
                                            {nullptr, 0, 0, 0, 0}, nullptr, 0, &gb, &def, big.data(), len, all),
                     REFL_STATUS_INVALID_ARGUMENT);
        std::vector<refl_vec3> nbig(16 * n, v3(0, 1, 0));
        refl_gbuffer alias = gb;
        alias.normals = {nbig.data(), n, w, h, w};
        CHECK_STATUS(refl_glossy_trace_rows(&st, reinterpret_cast<refl_glossy_texel*>(nbig.data()), n,
                                            {nullptr, 0, 0, 0, 0}, nullptr, 0, &alias, &def, pyr.data(), len, all),
                     REFL_STATUS_INVALID_ARGUMENT);
        CHECK(nbig[0].y == 1.0f && nbig[15 * n].y == 1.0f);
    }
}

}  // namespace

// A G-buffer of `cam`'s size over `depth` (zero-to-one) and world-space
// `normals`, without mask, roughness, color or back faces (the planar,
// layered and summary checks).
refl_gbuffer plain_gbuffer(const refl_camera& cam, const std::vector<float>& depth,
                           const std::vector<refl_vec3>& normals) {
    const uint32_t w = cam.width, h = cam.height;
    const refl_image_f32 none{nullptr, 0, 0, 0, 0};
    refl_gbuffer gb{};
    gb.depth = {{depth.data(), depth.size(), w, h, w}, cam, REFL_DEPTH_CONVENTION_ZERO_TO_ONE};
    gb.normals = {normals.data(), normals.size(), w, h, w};
    gb.normal_space = REFL_NORMAL_SPACE_WORLD;
    gb.mask = {nullptr, 0, 0, 0, 0};
    gb.roughness = none;
    gb.color = {nullptr, 0, 0, 0, 0};
    gb.back_depth = none;
    return gb;
}

// The planar mirror pass and the back-face depth helpers: NULL pointers,
// unknown enums, options out of range, bad planes, short, misaligned and
// aliased buffers, rows out of range, renders of another size. Every output
// (setup, stats, coverage bytes, texels, colors, host rays, dst) must be
// left untouched.
void planar_functions() {
    const refl_camera cam = good_camera();
    const uint32_t w = cam.width, h = cam.height;
    const size_t n = size_t(w) * h;
    // A floor y = 0 seen by every pixel below the horizon: [0, 1] depth of
    // the exact floor, normals +y, ids 0.
    std::vector<float> depth(n, 1.0f);
    std::vector<refl_vec3> normals(n, v3(0, 1, 0));
    std::vector<uint32_t> ids(n, 0u);
    for (uint32_t y = 0; y < h; ++y)
        for (uint32_t x = 0; x < w; ++x) {
            refl_ray r;
            REQUIRE(refl_camera_primary_ray(&r, &cam, v2(x + 0.5f, y + 0.5f)) == REFL_STATUS_OK);
            if (r.dir.y >= 0.0f) continue;
            const float t = -r.origin.y / r.dir.y;
            const refl_vec3 p = v3(r.origin.x + t * r.dir.x, 0.0f, r.origin.z + t * r.dir.z);
            float z = 0.0f;
            REQUIRE(refl_camera_linear_depth(&z, &cam, p) == REFL_STATUS_OK);
            REQUIRE(refl_camera_encode_depth(&depth[size_t(y) * w + x], &cam, z, REFL_DEPTH_CONVENTION_ZERO_TO_ONE) ==
                    REFL_STATUS_OK);
        }
    const refl_gbuffer gb = plain_gbuffer(cam, depth, normals);
    const refl_image_f32 none{nullptr, 0, 0, 0, 0};
    const refl_planar_mirror mirror{refl_plane{v3(0, 1, 0), 0.0f}, {ids.data(), n, w, h, w}, 0u};
    const refl_planar_options def = refl_planar_options_default();
    CHECK(def.scale == 1 && def.oblique && def.plane_tolerance > 0.0f);

    // Prepare.
    const refl_planar_setup setup = expect_ok<refl_planar_setup>(
        "planar prepare", [&](refl_planar_setup* o) { return refl_planar_prepare(o, &gb, &mirror, &def); });
    CHECK(setup.covered && setup.covered_pixels > n / 4 && setup.flip_winding);
    expect<refl_planar_setup>("planar prepare NULL gbuffer", REFL_STATUS_NULL_POINTER,
                              [&](refl_planar_setup* o) { return refl_planar_prepare(o, nullptr, &mirror, &def); });
    expect<refl_planar_setup>("planar prepare NULL mirror", REFL_STATUS_NULL_POINTER,
                              [&](refl_planar_setup* o) { return refl_planar_prepare(o, &gb, nullptr, &def); });
    expect<refl_planar_setup>("planar prepare NULL options", REFL_STATUS_NULL_POINTER,
                              [&](refl_planar_setup* o) { return refl_planar_prepare(o, &gb, &mirror, nullptr); });
    struct BadOptions {
        const char* what;
        void (*edit)(refl_planar_options&);
    };
    const BadOptions bad_options[] = {
        {"scale 0", [](refl_planar_options& o) { o.scale = 0; }},
        {"tolerance NaN", [](refl_planar_options& o) { o.plane_tolerance = kNaN; }},
        {"tolerance inf", [](refl_planar_options& o) { o.plane_tolerance = kInf; }},
        {"tolerance -1", [](refl_planar_options& o) { o.plane_tolerance = -1.0f; }},
        {"normal cos 2", [](refl_planar_options& o) { o.normal_cos = 2.0f; }},
        {"normal cos NaN", [](refl_planar_options& o) { o.normal_cos = kNaN; }},
        {"edge NaN", [](refl_planar_options& o) { o.edge_threshold = kNaN; }},
        {"edge -1", [](refl_planar_options& o) { o.edge_threshold = -1.0f; }},
    };
    for (const BadOptions& b : bad_options) {
        refl_planar_options o = def;
        b.edit(o);
        expect<refl_planar_setup>(b.what, REFL_STATUS_INVALID_ARGUMENT,
                                  [&](refl_planar_setup* out) { return refl_planar_prepare(out, &gb, &mirror, &o); });
    }
    {
        refl_planar_mirror m = mirror;
        m.plane.normal = v3(0, 0, 0);
        expect<refl_planar_setup>("planar prepare zero normal", REFL_STATUS_DEGENERATE_GEOMETRY,
                                  [&](refl_planar_setup* o) { return refl_planar_prepare(o, &gb, &m, &def); });
        for (const refl_vec3& bad : kBadVec3) {
            m = mirror;
            m.plane.normal = bad;
            expect<refl_planar_setup>("planar prepare bad normal", REFL_STATUS_INVALID_ARGUMENT,
                                      [&](refl_planar_setup* o) { return refl_planar_prepare(o, &gb, &m, &def); });
        }
        m = mirror;
        m.plane.d = kNaN;
        expect<refl_planar_setup>("planar prepare d NaN", REFL_STATUS_INVALID_ARGUMENT,
                                  [&](refl_planar_setup* o) { return refl_planar_prepare(o, &gb, &m, &def); });
        m = mirror;
        m.ids.width = w - 1;
        expect<refl_planar_setup>("planar prepare ids of another size", REFL_STATUS_INVALID_ARGUMENT,
                                  [&](refl_planar_setup* o) { return refl_planar_prepare(o, &gb, &m, &def); });
        m = mirror;
        m.ids.len = n - 1;
        expect<refl_planar_setup>("planar prepare short ids", REFL_STATUS_INSUFFICIENT_SIZE,
                                  [&](refl_planar_setup* o) { return refl_planar_prepare(o, &gb, &m, &def); });
        m = mirror;
        m.ids.data = reinterpret_cast<const uint32_t*>(reinterpret_cast<const char*>(ids.data()) + 1);
        expect<refl_planar_setup>("planar prepare misaligned ids", REFL_STATUS_INVALID_ARGUMENT,
                                  [&](refl_planar_setup* o) { return refl_planar_prepare(o, &gb, &m, &def); });
        refl_gbuffer b = gb;
        for (uint32_t c : kBadConventions) {
            b.depth.convention = c;
            expect<refl_planar_setup>("planar prepare bad convention", REFL_STATUS_INVALID_ARGUMENT,
                                      [&](refl_planar_setup* o) { return refl_planar_prepare(o, &b, &mirror, &def); });
        }
        b = gb;
        b.normal_space = 2;
        expect<refl_planar_setup>("planar prepare bad normal space", REFL_STATUS_INVALID_ARGUMENT,
                                  [&](refl_planar_setup* o) { return refl_planar_prepare(o, &b, &mirror, &def); });
        b = gb;
        b.normals.len = n - 1;
        expect<refl_planar_setup>("planar prepare short normals", REFL_STATUS_INSUFFICIENT_SIZE,
                                  [&](refl_planar_setup* o) { return refl_planar_prepare(o, &b, &mirror, &def); });
        for (const BadCamera& bc : bad_cameras()) {
            b = gb;
            b.depth.camera = bc.cam;
            expect<refl_planar_setup>(bc.name, bc.status,
                                      [&](refl_planar_setup* o) { return refl_planar_prepare(o, &b, &mirror, &def); });
        }
    }

    // Cover: stats and bytes untouched on error.
    const refl_row_range all{0, h};
    auto cover = [&](const char* what, refl_status want, const refl_gbuffer* g, const refl_planar_mirror* m,
                     const refl_planar_options* o, refl_row_range rows, size_t out_len, bool null_out = false) {
        std::vector<uint8_t> out(n + 1, 0xA7);
        expect<refl_planar_stats>(what, want, [&](refl_planar_stats* st) {
            return refl_planar_cover_rows(st, null_out ? nullptr : out.data(), out_len, g, m, o, rows);
        }, false);
        bool untouched = true;
        for (uint8_t b : out) untouched = untouched && b == 0xA7;
        CHECK(untouched);
    };
    const refl_planar_stats cs = expect_ok<refl_planar_stats>("planar cover", [&](refl_planar_stats* st) {
        std::vector<uint8_t> out(n);
        return refl_planar_cover_rows(st, out.data(), n, &gb, &mirror, &def, all);
    });
    CHECK_EQ(cs.covered, setup.covered_pixels);
    expect_ok<refl_planar_stats>("planar cover counts only", [&](refl_planar_stats* st) {
        return refl_planar_cover_rows(st, nullptr, 0, &gb, &mirror, &def, all);
    });
    CHECK_STATUS(refl_planar_cover_rows(nullptr, nullptr, 0, &gb, &mirror, &def, all), REFL_STATUS_NULL_POINTER);
    {
        Slot<refl_planar_stats> m;
        CHECK_STATUS(refl_planar_cover_rows(m.misaligned(), nullptr, 0, &gb, &mirror, &def, all),
                     REFL_STATUS_INVALID_ARGUMENT);
        CHECK(m.untouched());
    }
    cover("planar cover NULL out with a length", REFL_STATUS_NULL_POINTER, &gb, &mirror, &def, all, n, true);
    cover("planar cover NULL gbuffer", REFL_STATUS_NULL_POINTER, nullptr, &mirror, &def, all, n);
    cover("planar cover NULL mirror", REFL_STATUS_NULL_POINTER, &gb, nullptr, &def, all, n);
    cover("planar cover NULL options", REFL_STATUS_NULL_POINTER, &gb, &mirror, nullptr, all, n);
    cover("planar cover short out", REFL_STATUS_INSUFFICIENT_SIZE, &gb, &mirror, &def, all, n - 1);
    cover("planar cover reversed rows", REFL_STATUS_INVALID_ARGUMENT, &gb, &mirror, &def, {3, 2}, n);
    cover("planar cover rows past the end", REFL_STATUS_INVALID_ARGUMENT, &gb, &mirror, &def, {0, h + 1}, n);
    for (const BadOptions& b : bad_options) {
        refl_planar_options o = def;
        b.edit(o);
        cover(b.what, REFL_STATUS_INVALID_ARGUMENT, &gb, &mirror, &o, all, n);
    }
    {
        // The coverage bytes over the ids they read.
        std::vector<uint32_t> big(n + 4, 0u);
        refl_planar_mirror m = mirror;
        m.ids.data = big.data();
        refl_planar_stats st{};
        CHECK_STATUS(refl_planar_cover_rows(&st, reinterpret_cast<uint8_t*>(big.data()), n, &gb, &m, &def, all),
                     REFL_STATUS_INVALID_ARGUMENT);
        bool zero = true;
        for (uint32_t v : big) zero = zero && v == 0u;
        CHECK(zero);
    }

    // Resolve: a render of the setup camera's size (every texel a surface
    // at linear depth 20), every output prefilled.
    const uint32_t rw = setup.camera.width, rh = setup.camera.height;
    const size_t rn = size_t(rw) * rh;
    std::vector<float> rdepth(rn, 0.9f);
    std::vector<refl_vec3> rcolor(rn, v3(0.2f, 0.4f, 0.6f));
    const refl_planar_render render{{rdepth.data(), rn, rw, rh, rw}, {rcolor.data(), rn, rw, rh, rw}};
    auto resolve = [&](const char* what, refl_status want, const refl_gbuffer* g, const refl_planar_mirror* m,
                       const refl_planar_options* o, const refl_planar_render* r, refl_row_range rows, size_t out_len,
                       bool with_color, bool null_out = false, size_t host_len = 16, bool null_host = false) {
        std::vector<refl_planar_texel> out(n + 1);
        std::memset(static_cast<void*>(out.data()), 0x5A, out.size() * sizeof(refl_planar_texel));
        std::vector<refl_vec3> col(n, v3(-3, -3, -3));
        std::vector<refl_host_ray> host(16);
        std::memset(static_cast<void*>(host.data()), 0x6B, host.size() * sizeof(refl_host_ray));
        const refl_image_vec3_mut cm = with_color ? refl_image_vec3_mut{col.data(), n, w, h, w}
                                                  : refl_image_vec3_mut{nullptr, 0, 0, 0, 0};
        expect<refl_planar_stats>(what, want, [&](refl_planar_stats* st) {
            return refl_planar_resolve_rows(st, null_out ? nullptr : out.data(), out_len, cm,
                                            null_host ? nullptr : host.data(), host_len, g, m, o, r, rows);
        }, false);
        bool untouched = true;
        const unsigned char* ob = reinterpret_cast<const unsigned char*>(out.data());
        for (size_t i = 0; i < out.size() * sizeof(refl_planar_texel); ++i) untouched = untouched && ob[i] == 0x5A;
        const unsigned char* hb = reinterpret_cast<const unsigned char*>(host.data());
        for (size_t i = 0; i < host.size() * sizeof(refl_host_ray); ++i) untouched = untouched && hb[i] == 0x6B;
        for (const refl_vec3& c : col) untouched = untouched && c.x == -3.0f;
        CHECK(untouched);
    };
    const refl_planar_stats rs = expect_ok<refl_planar_stats>("planar resolve", [&](refl_planar_stats* st) {
        std::vector<refl_planar_texel> out(n);
        std::vector<refl_host_ray> host(n);
        std::vector<refl_vec3> col(n);
        return refl_planar_resolve_rows(st, out.data(), n, {col.data(), n, w, h, w}, host.data(), n, &gb, &mirror,
                                        &def, &render, all);
    });
    CHECK(rs.hits > 0 && rs.hits + rs.environment == setup.covered_pixels);
    CHECK_STATUS(refl_planar_resolve_rows(nullptr, nullptr, n, {nullptr, 0, 0, 0, 0}, nullptr, 0, &gb, &mirror, &def,
                                          &render, all),
                 REFL_STATUS_NULL_POINTER);
    resolve("planar resolve NULL out", REFL_STATUS_NULL_POINTER, &gb, &mirror, &def, &render, all, n, true, true);
    resolve("planar resolve NULL gbuffer", REFL_STATUS_NULL_POINTER, nullptr, &mirror, &def, &render, all, n, true);
    resolve("planar resolve NULL mirror", REFL_STATUS_NULL_POINTER, &gb, nullptr, &def, &render, all, n, true);
    resolve("planar resolve NULL options", REFL_STATUS_NULL_POINTER, &gb, &mirror, nullptr, &render, all, n, true);
    resolve("planar resolve NULL render", REFL_STATUS_NULL_POINTER, &gb, &mirror, &def, nullptr, all, n, true);
    resolve("planar resolve NULL host", REFL_STATUS_NULL_POINTER, &gb, &mirror, &def, &render, all, n, true, false, 16,
            true);
    resolve("planar resolve short out", REFL_STATUS_INSUFFICIENT_SIZE, &gb, &mirror, &def, &render, all, n - 1, true);
    resolve("planar resolve reversed rows", REFL_STATUS_INVALID_ARGUMENT, &gb, &mirror, &def, &render, {3, 2}, n, true);
    resolve("planar resolve rows past the end", REFL_STATUS_INVALID_ARGUMENT, &gb, &mirror, &def, &render, {0, h + 1},
            n, true);
    for (const BadOptions& b : bad_options) {
        refl_planar_options o = def;
        b.edit(o);
        resolve(b.what, REFL_STATUS_INVALID_ARGUMENT, &gb, &mirror, &o, &render, all, n, true);
    }
    {
        refl_planar_render r = render;
        r.depth.width = rw - 1;
        resolve("planar resolve render of another size", REFL_STATUS_INVALID_ARGUMENT, &gb, &mirror, &def, &r, all, n,
                true);
        refl_planar_options half = def;
        half.scale = 2;
        resolve("planar resolve render of another scale", REFL_STATUS_INVALID_ARGUMENT, &gb, &mirror, &half, &render,
                all, n, true);
        r = render;
        r.color = {nullptr, 0, 0, 0, 0};
        resolve("planar resolve color without a render color", REFL_STATUS_INVALID_ARGUMENT, &gb, &mirror, &def, &r,
                all, n, true);
        r = render;
        r.color.height = rh - 1;
        resolve("planar resolve render color of another size", REFL_STATUS_INVALID_ARGUMENT, &gb, &mirror, &def, &r,
                all, n, false);
        r = render;
        r.depth.data = nullptr;
        resolve("planar resolve NULL render depth", REFL_STATUS_NULL_POINTER, &gb, &mirror, &def, &r, all, n, true);
        r = render;
        r.depth.len = rn - 1;
        resolve("planar resolve short render depth", REFL_STATUS_INSUFFICIENT_SIZE, &gb, &mirror, &def, &r, all, n,
                true);
        // Misaligned texels; texels over the render depth they read.
        std::vector<refl_planar_texel> out(n + 1);
        refl_planar_stats st{};
        CHECK_STATUS(refl_planar_resolve_rows(
                         &st, reinterpret_cast<refl_planar_texel*>(reinterpret_cast<char*>(out.data()) + 1), n,
                         {nullptr, 0, 0, 0, 0}, nullptr, 0, &gb, &mirror, &def, &render, all),
                     REFL_STATUS_INVALID_ARGUMENT);
        std::vector<float> big(8 * n, 0.9f);
        r = render;
        r.depth.data = big.data();
        CHECK_STATUS(refl_planar_resolve_rows(&st, reinterpret_cast<refl_planar_texel*>(big.data()), n,
                                              {nullptr, 0, 0, 0, 0}, nullptr, 0, &gb, &mirror, &def, &r, all),
                     REFL_STATUS_INVALID_ARGUMENT);
        bool same = true;
        for (float v : big) same = same && v == 0.9f;
        CHECK(same);
    }

    // Back-face depth from a second pass: the front is the floor, the back
    // the cleared value.
    std::vector<float> back(n, 1.0f);
    const refl_depth_image front{{depth.data(), n, w, h, w}, cam, REFL_DEPTH_CONVENTION_ZERO_TO_ONE};
    const refl_image_f32 back_img{back.data(), n, w, h, w};
    auto back_depth = [&](const char* what, refl_status want, auto call) {
        std::vector<float> dst(n + 1, -9.0f);
        const refl_image_f32_mut d{dst.data(), n, w, h, w};
        expect<refl_trace_back_depth_stats>(what, want, [&](refl_trace_back_depth_stats* st) { return call(st, d); });
        bool untouched = true;
        for (float v : dst) untouched = untouched && v == -9.0f;
        CHECK(untouched);
    };
    const refl_trace_back_depth_stats bs = expect_ok<refl_trace_back_depth_stats>("back depth", [&](refl_trace_back_depth_stats* st) {
        std::vector<float> dst(n);
        return refl_trace_back_depth_rows(st, {dst.data(), n, w, h, w}, &front, back_img, all);
    });
    CHECK(bs.surfaces == setup.covered_pixels && bs.cleared == bs.surfaces);
    back_depth("back depth NULL front", REFL_STATUS_NULL_POINTER, [&](refl_trace_back_depth_stats* st, refl_image_f32_mut d) {
        return refl_trace_back_depth_rows(st, d, nullptr, back_img, all);
    });
    back_depth("back depth NULL back", REFL_STATUS_NULL_POINTER, [&](refl_trace_back_depth_stats* st, refl_image_f32_mut d) {
        return refl_trace_back_depth_rows(st, d, &front, none, all);
    });
    back_depth("back depth NULL dst", REFL_STATUS_NULL_POINTER, [&](refl_trace_back_depth_stats* st, refl_image_f32_mut d) {
        d.data = nullptr;
        return refl_trace_back_depth_rows(st, d, &front, back_img, all);
    });
    back_depth("back depth short dst", REFL_STATUS_INSUFFICIENT_SIZE, [&](refl_trace_back_depth_stats* st, refl_image_f32_mut d) {
        d.len = n - 1;
        return refl_trace_back_depth_rows(st, d, &front, back_img, all);
    });
    back_depth("back depth dst of another size", REFL_STATUS_INVALID_ARGUMENT, [&](refl_trace_back_depth_stats* st, refl_image_f32_mut d) {
        d.width = w - 1;
        return refl_trace_back_depth_rows(st, d, &front, back_img, all);
    });
    back_depth("back depth back of another size", REFL_STATUS_INVALID_ARGUMENT, [&](refl_trace_back_depth_stats* st, refl_image_f32_mut d) {
        refl_image_f32 b = back_img;
        b.height = h - 1;
        return refl_trace_back_depth_rows(st, d, &front, b, all);
    });
    back_depth("back depth misaligned dst", REFL_STATUS_INVALID_ARGUMENT, [&](refl_trace_back_depth_stats* st, refl_image_f32_mut d) {
        d.data = reinterpret_cast<float*>(reinterpret_cast<char*>(d.data) + 1);
        return refl_trace_back_depth_rows(st, d, &front, back_img, all);
    });
    back_depth("back depth rows past the end", REFL_STATUS_INVALID_ARGUMENT, [&](refl_trace_back_depth_stats* st, refl_image_f32_mut d) {
        return refl_trace_back_depth_rows(st, d, &front, back_img, refl_row_range{0, h + 1});
    });
    for (uint32_t c : kBadConventions) {
        refl_depth_image f = front;
        f.convention = c;
        back_depth("back depth bad convention", REFL_STATUS_INVALID_ARGUMENT, [&](refl_trace_back_depth_stats* st, refl_image_f32_mut d) {
            return refl_trace_back_depth_rows(st, d, &f, back_img, all);
        });
    }
    for (const BadCamera& bc : bad_cameras()) {
        refl_depth_image f = front;
        f.camera = bc.cam;
        back_depth(bc.name, bc.status, [&](refl_trace_back_depth_stats* st, refl_image_f32_mut d) {
            return refl_trace_back_depth_rows(st, d, &f, back_img, all);
        });
    }
    {
        // dst over the back it reads.
        std::vector<float> same = back;
        refl_trace_back_depth_stats st{};
        CHECK_STATUS(refl_trace_back_depth_rows(&st, {same.data(), n, w, h, w}, &front, {same.data(), n, w, h, w}, all),
                     REFL_STATUS_INVALID_ARGUMENT);
    }

    // Back-face depth from a layered map (an empty, cleared one: no exit).
    const float ident[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    refl_layered_grid grid{};
    grid.min = v3(-1, -1, -1);
    grid.max = v3(1, 1, 1);
    grid.face_res = 4;
    grid.layers = 1;
    std::memcpy(grid.world_from_local.m, ident, sizeof ident);
    refl_layered_sizes len{};
    REQUIRE(refl_layered_len(&len, 4, 1) == REFL_STATUS_OK);
    std::vector<float> mdepth(len.depth_len), mbounds(len.bounds_len);
    std::vector<uint32_t> mpayload(len.payload_len), mcounts(len.counts_len);
    const refl_layered_map_mut mm{grid,           mdepth.data(),  mdepth.size(),  mpayload.data(), mpayload.size(),
                                  mcounts.data(), mcounts.size(), mbounds.data(), mbounds.size()};
    const refl_layered_map map{grid,           mdepth.data(),  mdepth.size(),  mpayload.data(), mpayload.size(),
                               mcounts.data(), mcounts.size(), mbounds.data(), mbounds.size()};
    // Never cleared: no stamp.
    back_depth("back depth layered unstamped map", REFL_STATUS_INVALID_ARGUMENT, [&](refl_trace_back_depth_stats* st, refl_image_f32_mut d) {
        return refl_trace_back_depth_layered_rows(st, d, &front, &map, all);
    });
    REQUIRE(refl_layered_clear(&mm) == REFL_STATUS_OK);
    const refl_trace_back_depth_stats ls = expect_ok<refl_trace_back_depth_stats>("back depth layered", [&](refl_trace_back_depth_stats* st) {
        std::vector<float> dst(back);
        return refl_trace_back_depth_layered_rows(st, {dst.data(), n, w, h, w}, &front, &map, all);
    });
    CHECK(ls.exits == 0 && ls.surfaces == setup.covered_pixels);
    back_depth("back depth layered NULL map", REFL_STATUS_NULL_POINTER, [&](refl_trace_back_depth_stats* st, refl_image_f32_mut d) {
        return refl_trace_back_depth_layered_rows(st, d, &front, nullptr, all);
    });
    back_depth("back depth layered NULL front", REFL_STATUS_NULL_POINTER, [&](refl_trace_back_depth_stats* st, refl_image_f32_mut d) {
        return refl_trace_back_depth_layered_rows(st, d, nullptr, &map, all);
    });
    {
        refl_layered_map m = map;
        m.counts_len -= 1;
        back_depth("back depth layered short counts", REFL_STATUS_INSUFFICIENT_SIZE, [&](refl_trace_back_depth_stats* st, refl_image_f32_mut d) {
            return refl_trace_back_depth_layered_rows(st, d, &front, &m, all);
        });
        m = map;
        m.depth = nullptr;
        back_depth("back depth layered NULL map depth", REFL_STATUS_NULL_POINTER, [&](refl_trace_back_depth_stats* st, refl_image_f32_mut d) {
            return refl_trace_back_depth_layered_rows(st, d, &front, &m, all);
        });
        m = map;
        m.grid.max.y = m.grid.min.y;
        back_depth("back depth layered flat grid", REFL_STATUS_DEGENERATE_GEOMETRY, [&](refl_trace_back_depth_stats* st, refl_image_f32_mut d) {
            return refl_trace_back_depth_layered_rows(st, d, &front, &m, all);
        });
    }
    back_depth("back depth layered reversed rows", REFL_STATUS_INVALID_ARGUMENT, [&](refl_trace_back_depth_stats* st, refl_image_f32_mut d) {
        return refl_trace_back_depth_layered_rows(st, d, &front, &map, refl_row_range{2, 1});
    });
    {
        // dst over the map's depth buffer.
        std::vector<float> big(std::max(n, mdepth.size()), 0.5f);
        refl_layered_map m = map;
        m.depth = big.data();
        refl_trace_back_depth_stats st{};
        CHECK_STATUS(refl_trace_back_depth_layered_rows(&st, {big.data(), n, w, h, w}, &front, &m, all),
                     REFL_STATUS_INVALID_ARGUMENT);
    }
}

// The cluster pass: NULL pointers, options out of range, bad lobes, short,
// misaligned and aliased buffers, ids and renders of another size or
// camera, damaged plan entries, rows out of range. Every output (sizes,
// stats, entries, scratch, texels, host rays) must be left untouched.
void cluster_pass_functions() {
    const refl_camera cam = good_camera();
    const uint32_t w = cam.width, h = cam.height;
    const size_t n = size_t(w) * h;
    // A floor y = 0 (object 0, a mirror) below the horizon in linear depth.
    std::vector<float> depth(n, kInf);
    std::vector<refl_vec3> normals(n, v3(0, 1, 0));
    std::vector<uint32_t> ids(n, kMax);
    for (uint32_t y = 0; y < h; ++y)
        for (uint32_t x = 0; x < w; ++x) {
            refl_ray r;
            REQUIRE(refl_camera_primary_ray(&r, &cam, v2(x + 0.5f, y + 0.5f)) == REFL_STATUS_OK);
            if (r.dir.y >= 0.0f) continue;
            const float t = -r.origin.y / r.dir.y;
            const refl_vec3 p = v3(r.origin.x + t * r.dir.x, 0.0f, r.origin.z + t * r.dir.z);
            REQUIRE(refl_camera_linear_depth(&depth[size_t(y) * w + x], &cam, p) == REFL_STATUS_OK);
            ids[size_t(y) * w + x] = 0;
        }
    const refl_image_f32 none{nullptr, 0, 0, 0, 0};
    refl_gbuffer gb{};
    gb.depth = {{depth.data(), n, w, h, w}, cam, REFL_DEPTH_CONVENTION_LINEAR};
    gb.normals = {normals.data(), n, w, h, w};
    gb.normal_space = REFL_NORMAL_SPACE_WORLD;
    gb.mask = {nullptr, 0, 0, 0, 0};
    gb.roughness = none;
    gb.color = {nullptr, 0, 0, 0, 0};
    gb.back_depth = none;
    const refl_cluster_lobe lobes[1] = {{1, 0.0f, 0.0f}};
    const refl_cluster_objects objects{{ids.data(), n, w, h, w}, lobes, 1};
    refl_cluster_pass_options def = refl_cluster_pass_options_default();
    CHECK(def.cluster.max_theta_bins == 13 && def.thickness > 0.0f && def.refine && !def.fade);
    def.camera.far_distance = 30.0f;

    // Size query.
    const refl_cluster_plan_sizes sizes = expect_ok<refl_cluster_plan_sizes>(
        "cluster plan len", [&](refl_cluster_plan_sizes* o) { return refl_cluster_plan_len(o, &gb, &objects, &def); });
    CHECK(sizes.scratch_len >= 2 * n && sizes.clusters_len >= 1);
    expect<refl_cluster_plan_sizes>("cluster plan len NULL gbuffer", REFL_STATUS_NULL_POINTER, [&](refl_cluster_plan_sizes* o) {
        return refl_cluster_plan_len(o, nullptr, &objects, &def);
    });
    expect<refl_cluster_plan_sizes>("cluster plan len NULL objects", REFL_STATUS_NULL_POINTER, [&](refl_cluster_plan_sizes* o) {
        return refl_cluster_plan_len(o, &gb, nullptr, &def);
    });
    expect<refl_cluster_plan_sizes>("cluster plan len NULL options", REFL_STATUS_NULL_POINTER, [&](refl_cluster_plan_sizes* o) {
        return refl_cluster_plan_len(o, &gb, &objects, nullptr);
    });
    struct BadOptions {
        const char* what;
        void (*edit)(refl_cluster_pass_options&);
    };
    const BadOptions bad_options[] = {
        {"cluster gain NaN", [](refl_cluster_pass_options& o) { o.cluster.gain = kNaN; }},
        {"cluster theta bins 0", [](refl_cluster_pass_options& o) { o.cluster.max_theta_bins = 0; }},
        {"cluster phi bins huge", [](refl_cluster_pass_options& o) { o.cluster.max_phi_bins = kMax; }},
    };
    const BadOptions bad_pass_options[] = {
        {"cluster far NaN", [](refl_cluster_pass_options& o) { o.camera.far_distance = kNaN; }},
        {"cluster far 0", [](refl_cluster_pass_options& o) { o.camera.far_distance = 0.0f; }},
        {"cluster cone 2", [](refl_cluster_pass_options& o) { o.camera.cone_half_angle = 2.0f; }},
        {"cluster min pixels 1", [](refl_cluster_pass_options& o) { o.camera.min_pixels = 1; }},
        {"cluster thickness NaN", [](refl_cluster_pass_options& o) { o.thickness = kNaN; }},
        {"cluster thickness -1", [](refl_cluster_pass_options& o) { o.thickness = -1.0f; }},
        {"cluster stride 0", [](refl_cluster_pass_options& o) { o.step.stride = 0; }},
        {"cluster t_max 0", [](refl_cluster_pass_options& o) { o.t_max = 0.0f; }},
        {"cluster t_min inf", [](refl_cluster_pass_options& o) { o.t_min = kInf; }},
    };
    for (const BadOptions& b : bad_options) {
        refl_cluster_pass_options o = def;
        b.edit(o);
        expect<refl_cluster_plan_sizes>(b.what, REFL_STATUS_INVALID_ARGUMENT, [&](refl_cluster_plan_sizes* out) {
            return refl_cluster_plan_len(out, &gb, &objects, &o);
        });
    }
    for (const BadCamera& bc : bad_cameras()) {
        refl_gbuffer b = gb;
        b.depth.camera = bc.cam;
        expect<refl_cluster_plan_sizes>(bc.name, bc.status, [&](refl_cluster_plan_sizes* o) {
            return refl_cluster_plan_len(o, &b, &objects, &def);
        });
    }

    // Plan: stats, entries and scratch untouched on error.
    auto plan = [&](const char* what, refl_status want, const refl_gbuffer* g, const refl_cluster_objects* ob,
                    const refl_cluster_pass_options* o, size_t clusters_len, size_t scratch_len,
                    bool null_clusters = false, bool null_scratch = false) {
        std::vector<refl_cluster_plan_entry> list(sizes.clusters_len + 1);
        std::memset(static_cast<void*>(list.data()), 0x5A, list.size() * sizeof(refl_cluster_plan_entry));
        std::vector<uint32_t> scratch(sizes.scratch_len + 1, 0xA5A5A5A5u);
        expect<refl_cluster_plan_stats>(what, want, [&](refl_cluster_plan_stats* st) {
            return refl_cluster_plan(st, null_clusters ? nullptr : list.data(), clusters_len,
                                     null_scratch ? nullptr : scratch.data(), scratch_len, g, ob, o);
        }, false);
        bool untouched = true;
        const unsigned char* lb = reinterpret_cast<const unsigned char*>(list.data());
        for (size_t i = 0; i < list.size() * sizeof(refl_cluster_plan_entry); ++i) untouched = untouched && lb[i] == 0x5A;
        for (uint32_t v : scratch) untouched = untouched && v == 0xA5A5A5A5u;
        CHECK(untouched);
    };
    std::vector<refl_cluster_plan_entry> clusters(sizes.clusters_len);
    std::vector<uint32_t> scratch(sizes.scratch_len);
    const refl_cluster_plan_stats ps = expect_ok<refl_cluster_plan_stats>("cluster plan", [&](refl_cluster_plan_stats* st) {
        return refl_cluster_plan(st, clusters.data(), clusters.size(), scratch.data(), scratch.size(), &gb, &objects, &def);
    });
    CHECK(ps.clusters >= 1 && ps.cameras >= 1 && ps.pixels > n / 4);
    CHECK_STATUS(refl_cluster_plan(nullptr, clusters.data(), clusters.size(), scratch.data(), scratch.size(), &gb,
                                   &objects, &def),
                 REFL_STATUS_NULL_POINTER);
    const size_t cl = sizes.clusters_len, sl = sizes.scratch_len;
    plan("cluster plan NULL clusters", REFL_STATUS_NULL_POINTER, &gb, &objects, &def, cl, sl, true);
    plan("cluster plan NULL scratch", REFL_STATUS_NULL_POINTER, &gb, &objects, &def, cl, sl, false, true);
    plan("cluster plan NULL gbuffer", REFL_STATUS_NULL_POINTER, nullptr, &objects, &def, cl, sl);
    plan("cluster plan NULL objects", REFL_STATUS_NULL_POINTER, &gb, nullptr, &def, cl, sl);
    plan("cluster plan NULL options", REFL_STATUS_NULL_POINTER, &gb, &objects, nullptr, cl, sl);
    plan("cluster plan short clusters", REFL_STATUS_INSUFFICIENT_SIZE, &gb, &objects, &def, cl - 1, sl);
    plan("cluster plan short scratch", REFL_STATUS_INSUFFICIENT_SIZE, &gb, &objects, &def, cl, sl - 1);
    plan("cluster plan overflowing clusters_len", REFL_STATUS_INVALID_ARGUMENT, &gb, &objects, &def, SIZE_MAX / 2, sl);
    for (const BadOptions& b : bad_options) {
        refl_cluster_pass_options o = def;
        b.edit(o);
        plan(b.what, REFL_STATUS_INVALID_ARGUMENT, &gb, &objects, &o, cl, sl);
    }
    for (const BadOptions& b : bad_pass_options) {
        refl_cluster_pass_options o = def;
        b.edit(o);
        plan(b.what, REFL_STATUS_INVALID_ARGUMENT, &gb, &objects, &o, cl, sl);
    }
    {
        refl_cluster_objects ob = objects;
        ob.lobes = nullptr;
        plan("cluster plan NULL lobes", REFL_STATUS_NULL_POINTER, &gb, &ob, &def, cl, sl);
        const refl_cluster_lobe bad_lobes[4][1] = {
            {{0, 0.0f, 0.0f}}, {{65, 1.0f, 0.5f}}, {{8, kNaN, 0.5f}}, {{8, 10.0f, 2.0f}}};
        for (const auto& bl : bad_lobes) {
            ob = objects;
            ob.lobes = bl;
            plan("cluster plan bad lobe", REFL_STATUS_INVALID_ARGUMENT, &gb, &ob, &def, cl, sl);
        }
        ob = objects;
        ob.lobes = reinterpret_cast<const refl_cluster_lobe*>(reinterpret_cast<const char*>(lobes) + 1);
        plan("cluster plan misaligned lobes", REFL_STATUS_INVALID_ARGUMENT, &gb, &ob, &def, cl, sl);
        ob = objects;
        ob.ids.width = w - 1;
        plan("cluster plan ids of another size", REFL_STATUS_INVALID_ARGUMENT, &gb, &ob, &def, cl, sl);
        ob = objects;
        ob.ids.len = n - 1;
        plan("cluster plan short ids", REFL_STATUS_INSUFFICIENT_SIZE, &gb, &ob, &def, cl, sl);
        ob = objects;
        ob.ids.data = nullptr;
        plan("cluster plan NULL ids", REFL_STATUS_NULL_POINTER, &gb, &ob, &def, cl, sl);
        refl_gbuffer b = gb;
        for (uint32_t c : kBadConventions) {
            b.depth.convention = c;
            plan("cluster plan bad convention", REFL_STATUS_INVALID_ARGUMENT, &b, &objects, &def, cl, sl);
        }
        b = gb;
        b.normal_space = 2;
        plan("cluster plan bad normal space", REFL_STATUS_INVALID_ARGUMENT, &b, &objects, &def, cl, sl);
        b = gb;
        b.normals.len = n - 1;
        plan("cluster plan short normals", REFL_STATUS_INSUFFICIENT_SIZE, &b, &objects, &def, cl, sl);
        for (const BadCamera& bc : bad_cameras()) {
            b = gb;
            b.depth.camera = bc.cam;
            plan(bc.name, bc.status, &b, &objects, &def, cl, sl);
        }
        // The scratch over the ids it reads; the entries over the scratch.
        std::vector<uint32_t> big(sl + n, 0u);
        for (size_t i = 0; i < n; ++i) big[i] = ids[i];
        ob = objects;
        ob.ids.data = big.data();
        refl_cluster_plan_stats st{};
        CHECK_STATUS(refl_cluster_plan(&st, clusters.data(), clusters.size(), big.data(), sl, &gb, &ob, &def),
                     REFL_STATUS_INVALID_ARGUMENT);
        bool same = true;
        for (size_t i = 0; i < n; ++i) same = same && big[i] == ids[i];
        for (size_t i = n; i < big.size(); ++i) same = same && big[i] == 0u;
        CHECK(same);
        CHECK_STATUS(refl_cluster_plan(&st, reinterpret_cast<refl_cluster_plan_entry*>(big.data()), 1, big.data(),
                                       sl, &gb, &objects, &def),
                     REFL_STATUS_INSUFFICIENT_SIZE);
        // The scratch over the entries (both outputs).
        std::vector<uint32_t> both(sl + cl * sizeof(refl_cluster_plan_entry) / sizeof(uint32_t) + 4, 7u);
        CHECK_STATUS(refl_cluster_plan(&st, reinterpret_cast<refl_cluster_plan_entry*>(both.data()), cl, both.data(),
                                       sl, &gb, &objects, &def),
                     REFL_STATUS_INVALID_ARGUMENT);
        bool sevens = true;
        for (uint32_t v : both) sevens = sevens && v == 7u;
        CHECK(sevens);
    }

    // Finalize: an entry with a camera and a render of its size (every
    // texel a surface at linear depth 5), every output prefilled.
    const refl_cluster_plan_entry* withcam = nullptr;
    for (uint32_t c = 0; c < ps.clusters; ++c)
        if (clusters[c].camera.fallback == REFL_CLUSTER_FALLBACK_NONE) withcam = &clusters[c];
    REQUIRE(withcam != nullptr);
    const refl_cluster_plan_entry e = *withcam;
    const uint32_t rw = e.camera.camera.width, rh = e.camera.camera.height;
    const size_t rn = size_t(rw) * rh;
    std::vector<float> rdepth(rn, 5.0f);
    std::vector<refl_vec3> rcolor(rn, v3(0.2f, 0.4f, 0.6f));
    const refl_cluster_render render{{{rdepth.data(), rn, rw, rh, rw}, e.camera.camera, REFL_DEPTH_CONVENTION_LINEAR},
                                     {rcolor.data(), rn, rw, rh, rw},
                                     none,
                                     {nullptr, 0, 0, 0, 0},
                                     {nullptr, 0, 0, 0, 0}};
    auto finalize = [&](const char* what, refl_status want, const refl_gbuffer* g, const refl_cluster_pass_options* o,
                        const uint32_t* sc, size_t sc_len, const refl_cluster_plan_entry* entry,
                        const refl_cluster_render* r, refl_row_range rows, size_t out_len, bool null_out = false,
                        size_t host_len = 16, bool null_host = false) {
        std::vector<refl_cluster_texel> out(n + 1);
        std::memset(static_cast<void*>(out.data()), 0x5A, out.size() * sizeof(refl_cluster_texel));
        std::vector<refl_host_ray> host(16);
        std::memset(static_cast<void*>(host.data()), 0x6B, host.size() * sizeof(refl_host_ray));
        expect<refl_cluster_stats>(what, want, [&](refl_cluster_stats* st) {
            return refl_cluster_finalize_rows(st, null_out ? nullptr : out.data(), out_len,
                                              null_host ? nullptr : host.data(), host_len, g, o, sc, sc_len, entry, r,
                                              rows);
        }, false);
        bool untouched = true;
        const unsigned char* ob = reinterpret_cast<const unsigned char*>(out.data());
        for (size_t i = 0; i < out.size() * sizeof(refl_cluster_texel); ++i) untouched = untouched && ob[i] == 0x5A;
        const unsigned char* hb = reinterpret_cast<const unsigned char*>(host.data());
        for (size_t i = 0; i < host.size() * sizeof(refl_host_ray); ++i) untouched = untouched && hb[i] == 0x6B;
        CHECK(untouched);
    };
    const uint32_t* sc = scratch.data();
    const refl_cluster_stats fs = expect_ok<refl_cluster_stats>("cluster finalize", [&](refl_cluster_stats* st) {
        std::vector<refl_cluster_texel> out(n);
        std::vector<refl_host_ray> host(n);
        return refl_cluster_finalize_rows(st, out.data(), n, host.data(), n, &gb, &def, sc, sl, &e, &render, e.rows);
    });
    CHECK_EQ(fs.pixels, e.len);
    CHECK_STATUS(refl_cluster_finalize_rows(nullptr, nullptr, n, nullptr, 0, &gb, &def, sc, sl, &e, &render, e.rows),
                 REFL_STATUS_NULL_POINTER);
    finalize("cluster finalize NULL out", REFL_STATUS_NULL_POINTER, &gb, &def, sc, sl, &e, &render, e.rows, n, true);
    finalize("cluster finalize NULL host", REFL_STATUS_NULL_POINTER, &gb, &def, sc, sl, &e, &render, e.rows, n, false,
             16, true);
    finalize("cluster finalize NULL gbuffer", REFL_STATUS_NULL_POINTER, nullptr, &def, sc, sl, &e, &render, e.rows, n);
    finalize("cluster finalize NULL options", REFL_STATUS_NULL_POINTER, &gb, nullptr, sc, sl, &e, &render, e.rows, n);
    finalize("cluster finalize NULL scratch", REFL_STATUS_NULL_POINTER, &gb, &def, nullptr, sl, &e, &render, e.rows, n);
    finalize("cluster finalize NULL cluster", REFL_STATUS_NULL_POINTER, &gb, &def, sc, sl, nullptr, &render, e.rows, n);
    finalize("cluster finalize NULL render", REFL_STATUS_NULL_POINTER, &gb, &def, sc, sl, &e, nullptr, e.rows, n);
    finalize("cluster finalize short out", REFL_STATUS_INSUFFICIENT_SIZE, &gb, &def, sc, sl, &e, &render, e.rows,
             n - 1);
    finalize("cluster finalize short scratch", REFL_STATUS_INSUFFICIENT_SIZE, &gb, &def, sc, 2 * n - 1, &e, &render,
             e.rows, n);
    finalize("cluster finalize reversed rows", REFL_STATUS_INVALID_ARGUMENT, &gb, &def, sc, sl, &e, &render, {3, 2}, n);
    finalize("cluster finalize rows past the end", REFL_STATUS_INVALID_ARGUMENT, &gb, &def, sc, sl, &e, &render,
             {0, h + 1}, n);
    for (const BadOptions& b : bad_pass_options) {
        refl_cluster_pass_options o = def;
        b.edit(o);
        finalize(b.what, REFL_STATUS_INVALID_ARGUMENT, &gb, &o, sc, sl, &e, &render, e.rows, n);
    }
    {
        // Damaged entries.
        struct BadEntry {
            const char* what;
            void (*edit)(refl_cluster_plan_entry&);
        };
        const BadEntry bad_entries[] = {
            {"cluster entry centroid NaN", [](refl_cluster_plan_entry& x) { x.camera.centroid.x = kNaN; }},
            {"cluster entry normal 0", [](refl_cluster_plan_entry& x) { x.camera.normal = v3(0, 0, 0); }},
            {"cluster entry far inf", [](refl_cluster_plan_entry& x) { x.camera.far_distance = kInf; }},
            {"cluster entry clip NaN", [](refl_cluster_plan_entry& x) { x.camera.clip.d = kNaN; }},
            {"cluster entry camera NaN", [](refl_cluster_plan_entry& x) { x.camera.camera.fov_y = kNaN; }},
            {"cluster entry unknown fallback", [](refl_cluster_plan_entry& x) { x.camera.fallback = 99; }},
            {"cluster entry lobe 0 rays", [](refl_cluster_plan_entry& x) { x.lobe.rays = 0; }},
            {"cluster entry lobe NaN", [](refl_cluster_plan_entry& x) { x.lobe = {8, kNaN, 0.5f}; }},
            {"cluster entry pixels past the plan", [](refl_cluster_plan_entry& x) { x.first = kMax - 1; }},
            {"cluster entry rows reversed", [](refl_cluster_plan_entry& x) { x.rows = {3, 2}; }},
        };
        for (const BadEntry& b : bad_entries) {
            refl_cluster_plan_entry x = e;
            b.edit(x);
            finalize(b.what, REFL_STATUS_INVALID_ARGUMENT, &gb, &def, sc, sl, &x, &render, {0, h}, n);
        }
        // Renders of another camera or size.
        refl_cluster_render r = render;
        r.depth.camera.view.m[12] += 0.25f;
        finalize("cluster finalize render of another camera", REFL_STATUS_INVALID_ARGUMENT, &gb, &def, sc, sl, &e, &r,
                 e.rows, n);
        r = render;
        r.depth.camera.width += 1;
        finalize("cluster finalize render of another size", REFL_STATUS_INVALID_ARGUMENT, &gb, &def, sc, sl, &e, &r,
                 e.rows, n);
        r = render;
        r.color.height = rh - 1;
        finalize("cluster finalize color of another size", REFL_STATUS_INVALID_ARGUMENT, &gb, &def, sc, sl, &e, &r,
                 e.rows, n);
        std::vector<float> tiny(4, 1.0f);
        r = render;
        r.back_depth = {tiny.data(), 4, 2, 2, 2};
        finalize("cluster finalize back faces of another size", REFL_STATUS_INVALID_ARGUMENT, &gb, &def, sc, sl, &e, &r,
                 e.rows, n);
        r = render;
        r.depth.depth.data = nullptr;
        finalize("cluster finalize NULL render depth", REFL_STATUS_NULL_POINTER, &gb, &def, sc, sl, &e, &r, e.rows, n);
        r = render;
        r.color.len = rn - 1;
        finalize("cluster finalize short render color", REFL_STATUS_INSUFFICIENT_SIZE, &gb, &def, sc, sl, &e, &r,
                 e.rows, n);
        for (uint32_t c : kBadConventions) {
            r = render;
            r.depth.convention = c;
            finalize("cluster finalize bad convention", REFL_STATUS_INVALID_ARGUMENT, &gb, &def, sc, sl, &e, &r, e.rows,
                     n);
        }
        // A G-buffer that lost the cluster's surfaces (NaN normals).
        std::vector<refl_vec3> nan_normals(n, v3(kNaN, 0, 0));
        refl_gbuffer b = gb;
        b.normals.data = nan_normals.data();
        finalize("cluster finalize G-buffer without surfaces", REFL_STATUS_INVALID_ARGUMENT, &b, &def, sc, sl, &e,
                 &render, e.rows, n);
        // A damaged pixel list (an index past the image).
        std::vector<uint32_t> bad_scratch(scratch);
        bad_scratch[n + e.first] = kMax;
        finalize("cluster finalize damaged pixel list", REFL_STATUS_INVALID_ARGUMENT, &gb, &def, bad_scratch.data(), sl,
                 &e, &render, {0, h}, n);
        // Misaligned texels; texels over the scratch (the pixel lists) they read.
        std::vector<refl_cluster_texel> out(n + 1);
        refl_cluster_stats st{};
        CHECK_STATUS(refl_cluster_finalize_rows(
                         &st, reinterpret_cast<refl_cluster_texel*>(reinterpret_cast<char*>(out.data()) + 1), n, nullptr,
                         0, &gb, &def, sc, sl, &e, &render, e.rows),
                     REFL_STATUS_INVALID_ARGUMENT);
        std::vector<uint32_t> big(n * (sizeof(refl_cluster_texel) / sizeof(uint32_t) + 1), 0u);
        for (size_t i = 0; i < sl; ++i) big[i] = scratch[i];
        CHECK_STATUS(refl_cluster_finalize_rows(&st, reinterpret_cast<refl_cluster_texel*>(big.data()), n, nullptr, 0,
                                                &gb, &def, big.data(), sl, &e, &render, e.rows),
                     REFL_STATUS_INVALID_ARGUMENT);
        bool same = true;
        for (size_t i = 0; i < sl; ++i) same = same && big[i] == scratch[i];
        CHECK(same);
    }
}

// The layered-maps pass: NULL pointers, options out of range, maps that are
// not maps of their grid, ids and scratch of the wrong size, unprepared
// scratch, outputs aliasing inputs, rows out of range, hostile listed rays.
// Every output (scratch, stats, texels, colors, host rays) must be left
// untouched.
void layered_pass_functions() {
    const refl_camera cam = good_camera();
    const uint32_t w = cam.width, h = cam.height;
    const size_t n = size_t(w) * h;
    std::vector<float> depth(n, 0.5f);
    std::vector<refl_vec3> normals(n, v3(0, 1, 0));
    std::vector<uint32_t> ids(n, 0u);
    const refl_gbuffer gb = plain_gbuffer(cam, depth, normals);
    // One map, cleared (empty): a map of its grid.
    const float ident[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0.5f, 0, 1};
    refl_layered_grid grid{};
    grid.min = v3(-0.5f, -0.5f, -0.5f);
    grid.max = v3(0.5f, 0.5f, 0.5f);
    grid.face_res = 4;
    grid.layers = 1;
    std::memcpy(grid.world_from_local.m, ident, sizeof ident);
    refl_layered_sizes sz{};
    REQUIRE(refl_layered_len(&sz, 4, 1) == REFL_STATUS_OK);
    std::vector<float> mdepth(sz.depth_len), mbounds(sz.bounds_len);
    std::vector<uint32_t> mpayload(sz.payload_len), mcounts(sz.counts_len);
    const refl_layered_map_mut mm{grid,           mdepth.data(),  mdepth.size(),  mpayload.data(), mpayload.size(),
                                  mcounts.data(), mcounts.size(), mbounds.data(), mbounds.size()};
    REQUIRE(refl_layered_clear(&mm) == REFL_STATUS_OK);
    const refl_layered_map map{grid,           mdepth.data(),  mdepth.size(),  mpayload.data(), mpayload.size(),
                               mcounts.data(), mcounts.size(), mbounds.data(), mbounds.size()};
    const uint32_t map_ids[] = {3u};
    refl_layered_pass_input in{};
    in.gbuffer = gb;
    in.maps = &map;
    in.maps_len = 1;
    in.ids = {ids.data(), n, w, h, w};
    in.map_ids = map_ids;
    in.map_ids_len = 1;
    const refl_layered_pass_options def = refl_layered_pass_options_default();
    CHECK(def.start_pixels == 0.0f && def.t_max == kInf && !def.payload_color);

    // Scratch size.
    const size_t len =
        expect_ok<size_t>("layered pass scratch", [&](size_t* o) { return refl_layered_pass_scratch_len(o, &in, &def); });
    CHECK_EQ(len, size_t(1));
    expect<size_t>("layered pass scratch NULL input", REFL_STATUS_NULL_POINTER,
                   [&](size_t* o) { return refl_layered_pass_scratch_len(o, nullptr, &def); });
    expect<size_t>("layered pass scratch NULL options", REFL_STATUS_NULL_POINTER,
                   [&](size_t* o) { return refl_layered_pass_scratch_len(o, &in, nullptr); });

    // Hostile inputs, shared by prepare and the traces.
    struct BadInput {
        const char* what;
        refl_status st;
        refl_layered_pass_input in;
        refl_layered_pass_options o;
    };
    std::vector<BadInput> bad;
    auto add = [&](const char* what, refl_status st, auto edit) {
        BadInput b{what, st, in, def};
        edit(b.in, b.o);
        bad.push_back(b);
    };
    using I = refl_layered_pass_input;
    using O = refl_layered_pass_options;
    add("t_max NaN", REFL_STATUS_INVALID_ARGUMENT, [](I&, O& o) { o.t_max = kNaN; });
    add("t_max 0", REFL_STATUS_INVALID_ARGUMENT, [](I&, O& o) { o.t_max = 0.0f; });
    add("t_min -1", REFL_STATUS_INVALID_ARGUMENT, [](I&, O& o) { o.t_min = -1.0f; });
    add("t_min inf", REFL_STATUS_INVALID_ARGUMENT, [](I&, O& o) { o.t_min = kInf; });
    add("start NaN", REFL_STATUS_INVALID_ARGUMENT, [](I&, O& o) { o.start_pixels = kNaN; });
    add("roughness NaN", REFL_STATUS_INVALID_ARGUMENT, [](I&, O& o) { o.max_roughness = kNaN; });
    add("step 0", REFL_STATUS_INVALID_ARGUMENT, [](I&, O& o) { o.trace.step_texels = 0.0f; });
    add("step inf", REFL_STATUS_INVALID_ARGUMENT, [](I&, O& o) { o.trace.step_texels = kInf; });
    add("max steps 0", REFL_STATUS_INVALID_ARGUMENT, [](I&, O& o) { o.trace.max_steps = 0; });
    add("binary steps 65", REFL_STATUS_INVALID_ARGUMENT, [](I&, O& o) { o.trace.binary_steps = 65; });
    add("smooth NaN", REFL_STATUS_INVALID_ARGUMENT, [](I&, O& o) { o.trace.smooth_texels = kNaN; });
    add("maps NULL", REFL_STATUS_NULL_POINTER, [](I& i, O&) { i.maps = nullptr; });
    add("map ids NULL", REFL_STATUS_NULL_POINTER, [](I& i, O&) { i.map_ids = nullptr; });
    add("map ids short", REFL_STATUS_INSUFFICIENT_SIZE, [](I& i, O&) { i.map_ids_len = 0; });
    add("ids of another size", REFL_STATUS_INVALID_ARGUMENT, [](I& i, O&) { i.ids.width -= 1; });
    add("ids short", REFL_STATUS_INSUFFICIENT_SIZE, [](I& i, O&) { i.ids.len -= 1; });
    add("normals NULL", REFL_STATUS_NULL_POINTER, [](I& i, O&) { i.gbuffer.normals.data = nullptr; });
    add("normals of another size", REFL_STATUS_INVALID_ARGUMENT, [](I& i, O&) { i.gbuffer.normals.height -= 1; });
    add("bad normal space", REFL_STATUS_INVALID_ARGUMENT, [](I& i, O&) { i.gbuffer.normal_space = 7; });
    add("bad convention", REFL_STATUS_INVALID_ARGUMENT, [](I& i, O&) { i.gbuffer.depth.convention = kMax; });
    add("camera NaN", REFL_STATUS_INVALID_ARGUMENT, [](I& i, O&) { i.gbuffer.depth.camera.fov_y = kNaN; });
    // Map descriptors: another array of maps.
    static refl_layered_map maps_bad[6];
    for (auto& m : maps_bad) m = map;
    maps_bad[0].depth = nullptr;
    maps_bad[1].counts_len -= 1;
    maps_bad[2].grid.min.x = -0.6f;  // not the grid it was cleared for
    maps_bad[3].grid.world_from_local.m[3] = 0.5f;
    maps_bad[4].grid.world_from_local.m[13] = kNaN;
    maps_bad[5].bounds = reinterpret_cast<const float*>(reinterpret_cast<const char*>(mbounds.data()) + 1);
    const refl_status map_st[6] = {REFL_STATUS_NULL_POINTER, REFL_STATUS_INSUFFICIENT_SIZE,
                                   REFL_STATUS_INVALID_ARGUMENT, REFL_STATUS_INVALID_ARGUMENT,
                                   REFL_STATUS_INVALID_ARGUMENT, REFL_STATUS_INVALID_ARGUMENT};
    for (int k = 0; k < 6; ++k) {
        BadInput b{"bad map", map_st[k], in, def};
        b.in.maps = &maps_bad[k];
        bad.push_back(b);
    }

    // Prepare: the scratch is its output.
    auto prep = [&](const char* what, refl_status want, size_t scratch_len, const I* ip, const O* o,
                    bool null_scratch = false, bool misaligned = false) {
        std::vector<refl_layered_bound> scratch(4);
        std::memset(static_cast<void*>(scratch.data()), 0x3C, scratch.size() * sizeof(refl_layered_bound));
        refl_layered_bound* p = null_scratch ? nullptr : scratch.data();
        if (misaligned) p = reinterpret_cast<refl_layered_bound*>(reinterpret_cast<char*>(scratch.data()) + 1);
        const uint32_t got = refl_layered_pass_prepare(p, scratch_len, ip, o);
        ++check::checks();
        bool untouched = true;
        const unsigned char* sb = reinterpret_cast<const unsigned char*>(scratch.data());
        for (size_t i = 0; i < scratch.size() * sizeof(refl_layered_bound); ++i) untouched = untouched && sb[i] == 0x3C;
        if (got != static_cast<uint32_t>(want) || !untouched)
            check::fail(__FILE__, __LINE__, std::string(what) + ": got " + check::status_name(got));
    };
    prep("layered prepare NULL input", REFL_STATUS_NULL_POINTER, 1, nullptr, &def);
    prep("layered prepare NULL options", REFL_STATUS_NULL_POINTER, 1, &in, nullptr);
    prep("layered prepare NULL scratch", REFL_STATUS_NULL_POINTER, 1, &in, &def, true);
    prep("layered prepare misaligned scratch", REFL_STATUS_INVALID_ARGUMENT, 1, &in, &def, false, true);
    prep("layered prepare short scratch", REFL_STATUS_INSUFFICIENT_SIZE, 0, &in, &def);
    for (const BadInput& b : bad) prep(b.what, b.st, 1, &b.in, &b.o);
    {
        // A scratch over a map buffer it reads.
        std::vector<float> big(mdepth);
        refl_layered_map alias = map;
        alias.depth = big.data();
        I ai = in;
        ai.maps = &alias;
        CHECK_STATUS(refl_layered_pass_prepare(reinterpret_cast<refl_layered_bound*>(big.data()), 1, &ai, &def),
                     REFL_STATUS_INVALID_ARGUMENT);
        CHECK(big == mdepth);
    }

    // Traces: every output prefilled.
    refl_layered_bound scratch{};
    CHECK_STATUS(refl_layered_pass_prepare(&scratch, 1, &in, &def), REFL_STATUS_OK);
    const refl_row_range all{0, h};
    const refl_layered_pass_stats ok = expect_ok<refl_layered_pass_stats>("layered trace", [&](refl_layered_pass_stats* st) {
        std::vector<refl_layered_pass_texel> out(n);
        std::vector<refl_host_ray> host(n);
        return refl_layered_trace_rows(st, out.data(), n, {nullptr, 0, 0, 0, 0}, host.data(), n, &in, &def, &scratch,
                                       1, all);
    });
    CHECK(ok.traced > 0 && ok.host_rays == ok.traced);
    auto trace = [&](const char* what, refl_status want, const I* ip, const O* o, const refl_layered_bound* sc,
                     size_t sc_len, refl_row_range rows, size_t out_len, bool null_out = false, bool color = false,
                     uint32_t color_w = 0, bool null_host = false) {
        std::vector<refl_layered_pass_texel> out(n + 1);
        std::memset(static_cast<void*>(out.data()), 0x5A, out.size() * sizeof(refl_layered_pass_texel));
        std::vector<refl_vec3> col(n, v3(-3, -3, -3));
        std::vector<refl_host_ray> host(16);
        std::memset(static_cast<void*>(host.data()), 0x6B, host.size() * sizeof(refl_host_ray));
        const refl_image_vec3_mut cm =
            color ? refl_image_vec3_mut{col.data(), n, color_w, h, color_w} : refl_image_vec3_mut{nullptr, 0, 0, 0, 0};
        expect<refl_layered_pass_stats>(what, want, [&](refl_layered_pass_stats* st) {
            return refl_layered_trace_rows(st, null_out ? nullptr : out.data(), out_len, cm,
                                           null_host ? nullptr : host.data(), 16, ip, o, sc, sc_len, rows);
        }, false);
        bool untouched = true;
        const unsigned char* ob = reinterpret_cast<const unsigned char*>(out.data());
        for (size_t i = 0; i < out.size() * sizeof(refl_layered_pass_texel); ++i) untouched = untouched && ob[i] == 0x5A;
        const unsigned char* hb = reinterpret_cast<const unsigned char*>(host.data());
        for (size_t i = 0; i < host.size() * sizeof(refl_host_ray); ++i) untouched = untouched && hb[i] == 0x6B;
        for (const refl_vec3& c : col) untouched = untouched && c.x == -3.0f;
        CHECK(untouched);
    };
    CHECK_STATUS(refl_layered_trace_rows(nullptr, nullptr, n, {nullptr, 0, 0, 0, 0}, nullptr, 0, &in, &def, &scratch,
                                         1, all),
                 REFL_STATUS_NULL_POINTER);
    trace("layered trace NULL out", REFL_STATUS_NULL_POINTER, &in, &def, &scratch, 1, all, n, true);
    trace("layered trace NULL input", REFL_STATUS_NULL_POINTER, nullptr, &def, &scratch, 1, all, n);
    trace("layered trace NULL options", REFL_STATUS_NULL_POINTER, &in, nullptr, &scratch, 1, all, n);
    trace("layered trace NULL scratch", REFL_STATUS_NULL_POINTER, &in, &def, nullptr, 1, all, n);
    trace("layered trace NULL host", REFL_STATUS_NULL_POINTER, &in, &def, &scratch, 1, all, n, false, false, 0, true);
    trace("layered trace short out", REFL_STATUS_INSUFFICIENT_SIZE, &in, &def, &scratch, 1, all, n - 1);
    trace("layered trace short scratch", REFL_STATUS_INSUFFICIENT_SIZE, &in, &def, &scratch, 0, all, n);
    trace("layered trace reversed rows", REFL_STATUS_INVALID_ARGUMENT, &in, &def, &scratch, 1, {3, 2}, n);
    trace("layered trace rows past the end", REFL_STATUS_INVALID_ARGUMENT, &in, &def, &scratch, 1, {0, h + 1}, n);
    trace("layered trace color without payload colors", REFL_STATUS_INVALID_ARGUMENT, &in, &def, &scratch, 1, all, n,
          false, true, w);
    {
        O pc = def;
        pc.payload_color = true;
        trace("layered trace color of another size", REFL_STATUS_INVALID_ARGUMENT, &in, &pc, &scratch, 1, all, n,
              false, true, w - 1);
        refl_layered_bound blank{};
        trace("layered trace unprepared scratch", REFL_STATUS_INVALID_ARGUMENT, &in, &def, &blank, 1, all, n);
        refl_layered_map moved = map;
        moved.grid.world_from_local.m[12] = 0.25f;
        I mi = in;
        mi.maps = &moved;
        trace("layered trace scratch of a moved map", REFL_STATUS_INVALID_ARGUMENT, &mi, &def, &scratch, 1, all, n);
        refl_layered_bound nan = scratch;
        nan.center.x = kNaN;
        // A scratch whose key matches but whose sphere was overwritten: an
        // answer, never a crash.
        std::vector<refl_layered_pass_texel> out(n);
        refl_layered_pass_stats st{};
        CHECK_STATUS(refl_layered_trace_rows(&st, out.data(), n, {nullptr, 0, 0, 0, 0}, nullptr, 0, &in, &def, &nan,
                                             1, all),
                     REFL_STATUS_OK);
    }
    for (const BadInput& b : bad) trace(b.what, b.st, &b.in, &b.o, &scratch, 1, all, n);
    {
        // Texels aliasing the normals; host rays aliasing the scratch; misaligned texels.
        std::vector<refl_vec3> nbig(16 * n, v3(0, 1, 0));
        I alias = in;
        alias.gbuffer.normals = {nbig.data(), n, w, h, w};
        refl_layered_pass_stats st{};
        CHECK_STATUS(refl_layered_trace_rows(&st, reinterpret_cast<refl_layered_pass_texel*>(nbig.data()), n,
                                             {nullptr, 0, 0, 0, 0}, nullptr, 0, &alias, &def, &scratch, 1, all),
                     REFL_STATUS_INVALID_ARGUMENT);
        CHECK(nbig[0].y == 1.0f && nbig[15 * n].y == 1.0f);
        std::vector<refl_layered_pass_texel> out(n + 1);
        std::vector<refl_host_ray> hs(4);
        CHECK_STATUS(refl_layered_trace_rows(&st, out.data(), n, {nullptr, 0, 0, 0, 0}, hs.data(), 4, &in, &def,
                                             reinterpret_cast<const refl_layered_bound*>(hs.data()), 1, all),
                     REFL_STATUS_INVALID_ARGUMENT);
        CHECK_STATUS(refl_layered_trace_rows(&st,
                                             reinterpret_cast<refl_layered_pass_texel*>(
                                                 reinterpret_cast<char*>(out.data()) + 1),
                                             n, {nullptr, 0, 0, 0, 0}, nullptr, 0, &in, &def, &scratch, 1, all),
                     REFL_STATUS_INVALID_ARGUMENT);
    }

    // Potential reflection regions: the mask builder (NaN eye, short masks,
    // NULL triangles or scratch, too many maps, an infinite normal, masks
    // aliasing the triangles), then the pass with regions of another size,
    // NULL masks and a region id out of range. Nothing written.
    {
        const refl_vec3 c0 = v3(-2, -1, 2), c1 = v3(2, -1, 2), c2 = v3(0, -1, -4), up = v3(0, 1, 0);
        const refl_layered_prr_triangle tris[2] = {{{c0, c1, c2}, {up, up, up}},
                                                   {{c0, c2, c1}, {up, v3(0.2f, 1, 0), v3(0, 1, 0.2f)}}};
        uint64_t masks[2] = {0, 0};
        const refl_vec3 eye = v3(0, 1, 3);
        const refl_layered_prr_stats ps = expect_ok<refl_layered_prr_stats>(
            "prr masks", [&](refl_layered_prr_stats* st) { return refl_layered_prr_masks(st, masks, 2, tris, 2, eye, &scratch, 1); });
        CHECK(ps.regions == 2 && ps.pairs == 2);
        auto masks_refused = [&](const char* what, refl_status want, size_t masks_len, const refl_layered_prr_triangle* t,
                                 refl_vec3 e, const refl_layered_bound* sc, size_t sc_len) {
            uint64_t m[2] = {0x5A5A, 0x5A5A};
            expect<refl_layered_prr_stats>(what, want, [&](refl_layered_prr_stats* st) {
                return refl_layered_prr_masks(st, m, masks_len, t, 2, e, sc, sc_len);
            });
            CHECK(m[0] == 0x5A5A && m[1] == 0x5A5A);
        };
        masks_refused("prr masks NaN eye", REFL_STATUS_INVALID_ARGUMENT, 2, tris, v3(kNaN, 0, 0), &scratch, 1);
        masks_refused("prr masks short", REFL_STATUS_INSUFFICIENT_SIZE, 1, tris, eye, &scratch, 1);
        masks_refused("prr masks NULL triangles", REFL_STATUS_NULL_POINTER, 2, nullptr, eye, &scratch, 1);
        masks_refused("prr masks NULL scratch", REFL_STATUS_NULL_POINTER, 2, tris, eye, nullptr, 1);
        // 65 maps: two words per triangle.
        std::vector<refl_layered_bound> many(65, scratch);
        masks_refused("prr masks short for 65 maps", REFL_STATUS_INSUFFICIENT_SIZE, 2, tris, eye, many.data(), many.size());
        CHECK_EQ(expect_ok<size_t>("prr masks len", [&](size_t* o) { return refl_layered_prr_masks_len(o, 2, 65); }),
                 size_t(4));
        CHECK_STATUS(refl_layered_prr_masks_len(nullptr, 2, 65), REFL_STATUS_NULL_POINTER);
        refl_layered_prr_triangle bad[2] = {tris[0], tris[1]};
        bad[1].normals[2].y = kInf;
        masks_refused("prr masks infinite normal", REFL_STATUS_INVALID_ARGUMENT, 2, bad, eye, &scratch, 1);
        {
            refl_layered_prr_stats st{};
            CHECK_STATUS(refl_layered_prr_masks(&st, reinterpret_cast<uint64_t*>(bad), 2, bad, 2, eye, &scratch, 1),
                         REFL_STATUS_INVALID_ARGUMENT);
        }
        std::vector<uint32_t> regions(n, 0u);
        regions[1] = REFL_LAYERED_NO_REGION;
        I ri = in;
        ri.regions = {regions.data(), n, w, h, w};
        ri.region_masks = masks;
        ri.region_masks_len = 2;
        const refl_layered_pass_stats rs = expect_ok<refl_layered_pass_stats>("layered trace regions", [&](refl_layered_pass_stats* st) {
            std::vector<refl_layered_pass_texel> out(n);
            return refl_layered_trace_rows(st, out.data(), n, {nullptr, 0, 0, 0, 0}, nullptr, 0, &ri, &def, &scratch, 1, all);
        });
        CHECK(rs.traced == ok.traced && rs.hits == ok.hits);
        I other = ri;
        other.regions.width = w - 1;
        trace("layered trace regions of another size", REFL_STATUS_INVALID_ARGUMENT, &other, &def, &scratch, 1, all, n);
        I null_masks = ri;
        null_masks.region_masks = nullptr;
        trace("layered trace NULL region masks", REFL_STATUS_NULL_POINTER, &null_masks, &def, &scratch, 1, all, n);
        regions[n - 1] = 2;
        trace("layered trace region id out of range", REFL_STATUS_INVALID_ARGUMENT, &ri, &def, &scratch, 1, all, n);
    }

    // Listed rays.
    const refl_host_ray good{1, 2, v3(0, 1, 3), v3(0, 0, -1), 0.0f, kInf, 0};
    auto listed = [&](const char* what, refl_status want, std::vector<refl_host_ray> rays, size_t out_len,
                      bool color, size_t color_len, const O* o, const I* ip = nullptr) {
        std::vector<refl_layered_pass_texel> out(8);
        std::memset(static_cast<void*>(out.data()), 0x5A, out.size() * sizeof(refl_layered_pass_texel));
        std::vector<refl_vec3> col(8, v3(-3, -3, -3));
        std::vector<refl_host_ray> host(8);
        std::memset(static_cast<void*>(host.data()), 0x6B, host.size() * sizeof(refl_host_ray));
        expect<refl_layered_pass_stats>(what, want, [&](refl_layered_pass_stats* st) {
            return refl_layered_trace_host_rays(st, out.data(), out_len, color ? col.data() : nullptr, color_len,
                                                host.data(), 8, ip ? ip : &in, o, &scratch, 1, rays.data(),
                                                rays.size());
        }, want != REFL_STATUS_OK);
        if (want == REFL_STATUS_OK) return;
        bool untouched = true;
        const unsigned char* ob = reinterpret_cast<const unsigned char*>(out.data());
        for (size_t i = 0; i < out.size() * sizeof(refl_layered_pass_texel); ++i) untouched = untouched && ob[i] == 0x5A;
        const unsigned char* hb = reinterpret_cast<const unsigned char*>(host.data());
        for (size_t i = 0; i < host.size() * sizeof(refl_host_ray); ++i) untouched = untouched && hb[i] == 0x6B;
        for (const refl_vec3& c : col) untouched = untouched && c.x == -3.0f;
        CHECK(untouched);
    };
    const refl_layered_pass_stats lst = expect_ok<refl_layered_pass_stats>("layered host rays", [&](refl_layered_pass_stats* st) {
        std::vector<refl_layered_pass_texel> out(2);
        std::vector<refl_host_ray> host(2);
        const refl_host_ray rays[2] = {good, good};
        return refl_layered_trace_host_rays(st, out.data(), 2, nullptr, 0, host.data(), 2, &in, &def, &scratch, 1,
                                            rays, 2);
    });
    CHECK(lst.traced == 2 && lst.host_rays == 2);
    for (const refl_vec3& b : kBadVec3) {
        refl_host_ray r = good;
        r.origin = b;
        listed("host rays bad origin", REFL_STATUS_INVALID_ARGUMENT, {good, r}, 2, false, 0, &def);
        r = good;
        r.dir = b;
        listed("host rays bad dir", REFL_STATUS_INVALID_ARGUMENT, {good, r}, 2, false, 0, &def);
    }
    {
        refl_host_ray r = good;
        r.dir = v3(0, 0, -2);
        listed("host rays long dir", REFL_STATUS_INVALID_ARGUMENT, {r}, 1, false, 0, &def);
        r = good;
        r.dir = v3(0, 0, 0);
        listed("host rays zero dir", REFL_STATUS_INVALID_ARGUMENT, {r}, 1, false, 0, &def);
        for (float t : {kNaN, -1.0f, kInf}) {
            r = good;
            r.t_min = t;
            listed("host rays bad t_min", REFL_STATUS_INVALID_ARGUMENT, {r}, 1, false, 0, &def);
        }
        for (float t : {kNaN, 0.0f, -kInf}) {
            r = good;
            r.t_max = t;
            listed("host rays bad t_max", REFL_STATUS_INVALID_ARGUMENT, {r}, 1, false, 0, &def);
        }
        r = good;
        r.origin = v3(0, 0, 3e38f);
        r.dir = v3(0, 0, 1);
        r.t_min = 1e38f;
        listed("host rays start overflows", REFL_STATUS_INVALID_ARGUMENT, {r}, 1, false, 0, &def);
        listed("host rays short out", REFL_STATUS_INSUFFICIENT_SIZE, {good, good}, 1, false, 0, &def);
        O pc = def;
        pc.payload_color = true;
        listed("host rays short color", REFL_STATUS_INSUFFICIENT_SIZE, {good, good}, 2, true, 1, &pc);
        listed("host rays color without payload colors", REFL_STATUS_INVALID_ARGUMENT, {good}, 1, true, 1, &def);
        listed("host rays NULL options", REFL_STATUS_NULL_POINTER, {good}, 1, false, 0, nullptr);
        for (const BadInput& b : bad) listed(b.what, b.st, {good}, 1, false, 0, &b.o, &b.in);
        // NULL rays with a count; out aliasing the rays.
        refl_layered_pass_stats st{};
        std::vector<refl_layered_pass_texel> out(2);
        CHECK_STATUS(refl_layered_trace_host_rays(&st, out.data(), 2, nullptr, 0, nullptr, 0, &in, &def, &scratch, 1,
                                                  nullptr, 2),
                     REFL_STATUS_NULL_POINTER);
        std::vector<refl_host_ray> rays(8, good);
        CHECK_STATUS(refl_layered_trace_host_rays(&st, reinterpret_cast<refl_layered_pass_texel*>(rays.data()), 1,
                                                  nullptr, 0, nullptr, 0, &in, &def, &scratch, 1, rays.data() + 1, 1),
                     REFL_STATUS_INVALID_ARGUMENT);
        CHECK(rays[0].x == good.x && rays[1].t_max == kInf);
        CHECK_STATUS(refl_layered_trace_host_rays(&st, out.data(), 2, nullptr, 0, rays.data(), 4, &in, &def,
                                                  &scratch, 1, rays.data() + 2, 2),
                     REFL_STATUS_INVALID_ARGUMENT);
        // Zero rays: nothing to trace, the inputs still checked.
        CHECK_STATUS(refl_layered_trace_host_rays(&st, nullptr, 0, nullptr, 0, nullptr, 0, &in, &def, &scratch, 1,
                                                  nullptr, 0),
                     REFL_STATUS_OK);
        CHECK(st.traced == 0);
    }
}

// The temporal filter: NULL pointers, options out of range (NaN, Inf),
// rows out of range, images of other sizes, short and misaligned buffers,
// a history of another size or an invalid camera, the next history over
// the one read, outputs aliasing inputs or each other, unknown enums.
// Every output (stats, next history, statuses) must be left untouched.
void temporal_functions() {
    const refl_camera g = good_camera();
    const uint32_t w = g.width, h = g.height;
    const size_t n = size_t(w) * h;
    std::vector<float> depth(n, 0.5f), distance(n, 2.0f);
    std::vector<refl_vec3> normals(n, v3(0, 1, 0)), current(n, v3(0.5f, 0.25f, 0.125f));
    std::vector<uint8_t> answered(n, 1);
    const refl_image_f32 none{nullptr, 0, 0, 0, 0};
    refl_gbuffer gb{};
    gb.depth = {{depth.data(), n, w, h, w}, g, REFL_DEPTH_CONVENTION_ZERO_TO_ONE};
    gb.normals = {normals.data(), n, w, h, w};
    gb.normal_space = REFL_NORMAL_SPACE_WORLD;
    gb.mask = {nullptr, 0, 0, 0, 0};
    gb.roughness = none;
    gb.color = {nullptr, 0, 0, 0, 0};
    gb.back_depth = none;
    const refl_temporal_options def = refl_temporal_options_default();
    CHECK(def.max_frames == 8.0f && def.depth_tolerance == 0.02f && def.normal_cos == 0.9f && def.recover && def.clamp_history);
    const refl_row_range all{0, h};

    // A first frame without history (its camera ignored, here invalid),
    // then the history it wrote.
    std::vector<refl_temporal_texel> first(n);
    refl_camera zero{};
    std::memset(static_cast<void*>(&zero), 0, sizeof zero);
    const refl_temporal_history nothing{zero, {nullptr, 0, 0, 0, 0}};
    const refl_temporal_stats st0 = expect_ok<refl_temporal_stats>("temporal first frame", [&](refl_temporal_stats* st) {
        return refl_temporal_resolve_rows(st, {first.data(), n, w, h, w}, {nullptr, 0, 0, 0, 0}, &gb,
                                          {current.data(), n, w, h, w}, {answered.data(), n, w, h, w}, none,
                                          &nothing, &def, all);
    });
    CHECK_EQ(st0.reset, uint32_t(n));
    const refl_temporal_history hist{g, {first.data(), n, w, h, w}};
    const std::vector<refl_temporal_texel> first_copy = first;

    struct Args {
        refl_image_temporal_texel_mut next;
        refl_image_u8_mut status;
        const refl_gbuffer* gbuffer;
        refl_image_vec3 current;
        refl_image_u8 answered;
        refl_image_f32 distance;
        const refl_temporal_history* history;
        const refl_temporal_options* options;
        refl_row_range rows;
    };
    // Calls the filter with every output prefilled and `edit` applied to
    // valid arguments; checks the status and that no output byte changed
    // (with `pointers`, also a NULL and a misaligned `out_stats`).
    auto check = [&](const char* what, refl_status want, auto edit, bool pointers = false) {
        std::vector<refl_temporal_texel> out(n + 1);
        std::memset(static_cast<void*>(out.data()), 0x5A, out.size() * sizeof(refl_temporal_texel));
        std::vector<uint8_t> stat(n + 1, 0x6B);
        Args a{{out.data(), n, w, h, w},
               {stat.data(), n, w, h, w},
               &gb,
               {current.data(), n, w, h, w},
               {answered.data(), n, w, h, w},
               {distance.data(), n, w, h, w},
               &hist,
               &def,
               all};
        edit(a);
        expect<refl_temporal_stats>(what, want, [&](refl_temporal_stats* st) {
            return refl_temporal_resolve_rows(st, a.next, a.status, a.gbuffer, a.current, a.answered, a.distance,
                                              a.history, a.options, a.rows);
        }, pointers);
        bool untouched = true;
        const unsigned char* ob = reinterpret_cast<const unsigned char*>(out.data());
        for (size_t i = 0; i < out.size() * sizeof(refl_temporal_texel); ++i) untouched = untouched && ob[i] == 0x5A;
        for (uint8_t v : stat) untouched = untouched && v == 0x6B;
        if (!untouched) check::fail(__FILE__, __LINE__, std::string(what) + ": an output was written");
        // The history and the inputs are never written.
        CHECK(std::memcmp(first.data(), first_copy.data(), n * sizeof(refl_temporal_texel)) == 0);
        CHECK(answered[0] == 1 && answered[n - 1] == 1 && current[0].x == 0.5f && current[n - 1].x == 0.5f);
    };

    // A band with distances and statuses: the other rows stay as they were.
    {
        std::vector<refl_temporal_texel> out(n);
        std::memset(static_cast<void*>(out.data()), 0x5A, n * sizeof(refl_temporal_texel));
        std::vector<uint8_t> stat(n, 0x6B);
        const refl_temporal_stats st = expect_ok<refl_temporal_stats>("temporal band", [&](refl_temporal_stats* s) {
            return refl_temporal_resolve_rows(s, {out.data(), n, w, h, w}, {stat.data(), n, w, h, w}, &gb,
                                              {current.data(), n, w, h, w}, {answered.data(), n, w, h, w},
                                              {distance.data(), n, w, h, w}, &hist, &def, {2, 5});
        });
        CHECK_EQ(st.blended, 3 * w);
        bool outside = true, inside = true;
        const unsigned char* ob = reinterpret_cast<const unsigned char*>(out.data());
        for (size_t i = 0; i < n * sizeof(refl_temporal_texel); ++i) {
            const size_t row = i / sizeof(refl_temporal_texel) / w;
            if (row < 2 || row >= 5) outside = outside && ob[i] == 0x5A;
        }
        for (size_t i = 0; i < n; ++i) {
            const size_t row = i / w;
            if (row < 2 || row >= 5) outside = outside && stat[i] == 0x6B;
            else inside = inside && stat[i] == REFL_TEMPORAL_STATUS_BLENDED && out[i].frames == 2.0f;
        }
        CHECK(outside);
        CHECK(inside);
    }

    // NULL pointers.
    check("temporal rows reversed (and NULL / misaligned stats)", REFL_STATUS_INVALID_ARGUMENT,
          [](Args& a) { a.rows = {3, 2}; }, true);
    check("temporal NULL next", REFL_STATUS_NULL_POINTER, [](Args& a) { a.next.data = nullptr; });
    check("temporal NULL gbuffer", REFL_STATUS_NULL_POINTER, [](Args& a) { a.gbuffer = nullptr; });
    check("temporal NULL current", REFL_STATUS_NULL_POINTER, [](Args& a) { a.current.data = nullptr; });
    check("temporal NULL answered", REFL_STATUS_NULL_POINTER, [](Args& a) { a.answered.data = nullptr; });
    check("temporal NULL history", REFL_STATUS_NULL_POINTER, [](Args& a) { a.history = nullptr; });
    check("temporal NULL options", REFL_STATUS_NULL_POINTER, [](Args& a) { a.options = nullptr; });
    refl_gbuffer no_normals = gb;
    no_normals.normals.data = nullptr;
    no_normals.depth.depth.len = 3;
    check("temporal NULL normals, short depth", REFL_STATUS_NULL_POINTER,
          [&](Args& a) { a.gbuffer = &no_normals; });
    check("temporal NULL current, short next", REFL_STATUS_NULL_POINTER, [](Args& a) {
        a.current.data = nullptr;
        a.next.len = 1;
    });

    // Options out of range.
    std::vector<refl_temporal_options> bad_options;
    for (float v : {kNaN, 0.5f, 0.0f, -kInf, -1.0f}) {
        refl_temporal_options o = def;
        o.max_frames = v;
        bad_options.push_back(o);
    }
    for (float v : {kNaN, -0.01f, kInf, -kInf}) {
        refl_temporal_options o = def;
        o.depth_tolerance = v;
        bad_options.push_back(o);
    }
    for (float v : {kNaN, 1.5f, -1.01f, kInf, -kInf}) {
        refl_temporal_options o = def;
        o.normal_cos = v;
        bad_options.push_back(o);
    }
    {
        // Every float field of 0xFF bytes (NaN).
        refl_temporal_options o = def;
        std::memset(static_cast<void*>(&o), 0xFF, offsetof(refl_temporal_options, recover));
        bad_options.push_back(o);
    }
    for (const refl_temporal_options& o : bad_options)
        check("temporal bad options", REFL_STATUS_INVALID_ARGUMENT, [&](Args& a) { a.options = &o; });
    {
        // The ends of the ranges are accepted.
        const refl_temporal_options ends{kInf, 0.0f, -1.0f, false, false};
        std::vector<refl_temporal_texel> out(n);
        expect_ok<refl_temporal_stats>("temporal range ends", [&](refl_temporal_stats* s) {
            return refl_temporal_resolve_rows(s, {out.data(), n, w, h, w}, {nullptr, 0, 0, 0, 0}, &gb,
                                              {current.data(), n, w, h, w}, {answered.data(), n, w, h, w},
                                              none, &hist, &ends, all);
        });
    }

    // Rows, sizes, strides, lengths, misaligned buffers.
    check("temporal rows past the end", REFL_STATUS_INVALID_ARGUMENT, [&](Args& a) { a.rows = {0, h + 1}; });
    check("temporal empty rows", REFL_STATUS_INVALID_ARGUMENT, [](Args& a) { a.rows = {5, 5}; });
    check("temporal rows at kMax", REFL_STATUS_INVALID_ARGUMENT, [](Args& a) { a.rows = {kMax, kMax}; });
    check("temporal short next", REFL_STATUS_INSUFFICIENT_SIZE, [&](Args& a) { a.next.len = n - 1; });
    check("temporal next of another size", REFL_STATUS_INVALID_ARGUMENT, [&](Args& a) { a.next.height = h - 1; });
    check("temporal next stride below width", REFL_STATUS_INVALID_ARGUMENT, [&](Args& a) { a.next.stride = w - 1; });
    check("temporal next of zero width", REFL_STATUS_INVALID_ARGUMENT, [](Args& a) { a.next.width = 0; });
    check("temporal misaligned next", REFL_STATUS_INVALID_ARGUMENT, [](Args& a) {
        a.next.data = reinterpret_cast<refl_temporal_texel*>(reinterpret_cast<char*>(a.next.data) + 1);
    });
    check("temporal short status", REFL_STATUS_INSUFFICIENT_SIZE, [&](Args& a) { a.status.len = n - 1; });
    check("temporal status of another size", REFL_STATUS_INVALID_ARGUMENT, [&](Args& a) { a.status.width = w + 1; });
    check("temporal short current", REFL_STATUS_INSUFFICIENT_SIZE, [&](Args& a) { a.current.len = n - 1; });
    check("temporal current of another size", REFL_STATUS_INVALID_ARGUMENT, [&](Args& a) { a.current.height = h - 1; });
    check("temporal current stride 0", REFL_STATUS_INVALID_ARGUMENT, [](Args& a) { a.current.stride = 0; });
    check("temporal misaligned current", REFL_STATUS_INVALID_ARGUMENT, [](Args& a) {
        a.current.data = reinterpret_cast<const refl_vec3*>(reinterpret_cast<const char*>(a.current.data) + 2);
        a.current.len -= 1;
    });
    check("temporal short answered", REFL_STATUS_INSUFFICIENT_SIZE, [](Args& a) { a.answered.len = 0; });
    check("temporal answered of another size", REFL_STATUS_INVALID_ARGUMENT, [&](Args& a) { a.answered.width = w - 1; });
    check("temporal short distance", REFL_STATUS_INSUFFICIENT_SIZE, [&](Args& a) { a.distance.len = n - 1; });
    check("temporal distance of another size", REFL_STATUS_INVALID_ARGUMENT,
          [&](Args& a) { a.distance.height = h / 2; });
    check("temporal huge current (needs more texels than len)", REFL_STATUS_INSUFFICIENT_SIZE, [](Args& a) {
        a.current.width = kMax;
        a.current.height = kMax;
        a.current.stride = kMax;
    });

    // Histories: of another size, texels not of their camera's size, short,
    // misaligned, invalid cameras.
    refl_camera small = g;
    REQUIRE(refl_camera_look_at(&small, v3(1, 2, 5), v3(0, 0.5f, 0), v3(0, 1, 0), 1.0f, 0.1f, 100.0f, w, h - 1) ==
            REFL_STATUS_OK);
    const refl_temporal_history other_size{small, {first.data(), n, w, h - 1, w}};
    check("temporal history of another size", REFL_STATUS_INVALID_ARGUMENT,
          [&](Args& a) { a.history = &other_size; });
    const refl_temporal_history texels_not_camera{g, {first.data(), n, w, h - 1, w}};
    check("temporal history texels not of their camera", REFL_STATUS_INVALID_ARGUMENT,
          [&](Args& a) { a.history = &texels_not_camera; });
    const refl_temporal_history short_history{g, {first.data(), n - 1, w, h, w}};
    check("temporal short history", REFL_STATUS_INSUFFICIENT_SIZE, [&](Args& a) { a.history = &short_history; });
    std::vector<unsigned char> raw((n + 1) * sizeof(refl_temporal_texel));
    const refl_temporal_history misaligned_history{
        g, {reinterpret_cast<const refl_temporal_texel*>(raw.data() + 1), n, w, h, w}};
    check("temporal misaligned history", REFL_STATUS_INVALID_ARGUMENT,
          [&](Args& a) { a.history = &misaligned_history; });
    const std::vector<BadCamera> bad = bad_cameras();
    std::vector<refl_temporal_history> bad_histories;
    std::vector<refl_gbuffer> bad_gbuffers;
    for (const BadCamera& bc : bad) {
        bad_histories.push_back({bc.cam, hist.texels});
        refl_gbuffer b = gb;
        b.depth.camera = bc.cam;
        bad_gbuffers.push_back(b);
    }
    for (size_t i = 0; i < bad.size(); ++i) {
        check(bad[i].name, bad[i].status, [&](Args& a) { a.history = &bad_histories[i]; });
        check(bad[i].name, bad[i].status, [&](Args& a) { a.gbuffer = &bad_gbuffers[i]; });
    }
    // Enums of the G-buffer.
    refl_gbuffer bad_space = gb;
    bad_space.normal_space = 2;
    check("temporal bad normal space", REFL_STATUS_INVALID_ARGUMENT, [&](Args& a) { a.gbuffer = &bad_space; });
    for (uint32_t c : kBadConventions) {
        refl_gbuffer bc = gb;
        bc.depth.convention = c;
        check("temporal bad convention", REFL_STATUS_INVALID_ARGUMENT, [&](Args& a) { a.gbuffer = &bc; });
    }

    // Aliasing: the next history over the one read, over an input; the
    // statuses over an input or the next history.
    check("temporal next in place of the history", REFL_STATUS_INVALID_ARGUMENT,
          [&](Args& a) { a.next.data = first.data(); });
    check("temporal next over current", REFL_STATUS_INVALID_ARGUMENT,
          [&](Args& a) { a.next.data = reinterpret_cast<refl_temporal_texel*>(current.data()); });
    check("temporal status over answered", REFL_STATUS_INVALID_ARGUMENT,
          [&](Args& a) { a.status.data = answered.data(); });
    check("temporal status over next", REFL_STATUS_INVALID_ARGUMENT,
          [](Args& a) { a.status.data = reinterpret_cast<uint8_t*>(a.next.data) + 40; });
    check("temporal status over the depth", REFL_STATUS_INVALID_ARGUMENT,
          [&](Args& a) { a.status.data = reinterpret_cast<uint8_t*>(depth.data()); });
    {
        std::vector<refl_temporal_texel> out(n);
        std::memset(static_cast<void*>(out.data()), 0x5A, n * sizeof(refl_temporal_texel));
        CHECK_STATUS(refl_temporal_resolve_rows(reinterpret_cast<refl_temporal_stats*>(out.data() + 3),
                                                {out.data(), n, w, h, w}, {nullptr, 0, 0, 0, 0}, &gb,
                                                {current.data(), n, w, h, w}, {answered.data(), n, w, h, w}, none,
                                                &hist, &def, all),
                     REFL_STATUS_INVALID_ARGUMENT);
        const unsigned char* ob = reinterpret_cast<const unsigned char*>(out.data());
        bool untouched = true;
        for (size_t i = 0; i < n * sizeof(refl_temporal_texel); ++i) untouched = untouched && ob[i] == 0x5A;
        CHECK(untouched);
    }
}


// Bounces, extrapolation and upsampling (issue 18): NULL pointers, options
// out of range, rows, sizes, short and misaligned buffers, texel statuses
// that are not a refl_ssr_status, unknown patterns, outputs aliasing inputs
// or each other. Every output must be left untouched; a band leaves the
// other rows alone.
void bounce_extrapolate_upsample_functions() {
    const refl_camera g = good_camera();
    const uint32_t w = g.width, h = g.height;
    const size_t n = size_t(w) * h;
    std::vector<float> depth(n, 0.5f);
    std::vector<refl_vec3> normals(n, v3(0, 1, 0)), lit(n, v3(0.5f, 0.25f, 0.125f)), last(n, v3(1, 0, 0));
    const refl_image_f32 none{nullptr, 0, 0, 0, 0};
    refl_gbuffer gb{};
    gb.depth = {{depth.data(), n, w, h, w}, g, REFL_DEPTH_CONVENTION_ZERO_TO_ONE};
    gb.normals = {normals.data(), n, w, h, w};
    gb.normal_space = REFL_NORMAL_SPACE_WORLD;
    gb.mask = {nullptr, 0, 0, 0, 0};
    gb.roughness = none;
    gb.color = {lit.data(), n, w, h, w};
    gb.back_depth = none;
    const refl_row_range all{0, h};

    // Compares a buffer with its fill byte.
    auto filled = [](const void* p, size_t bytes, unsigned char v) {
        const unsigned char* b = static_cast<const unsigned char*>(p);
        for (size_t i = 0; i < bytes; ++i)
            if (b[i] != v) return false;
        return true;
    };

    // --- Bounces.
    const refl_bounce_options bdef = refl_bounce_options_default();
    CHECK(bdef.attenuation == 1.0f && bdef.depth_tolerance == 0.02f);
    const refl_bounce_previous prev{gb.depth, {last.data(), n, w, h, w}};
    {
        // A band: a static camera re-projects every pixel; the other rows
        // stay as they were.
        std::vector<refl_vec3> out(n);
        std::memset(static_cast<void*>(out.data()), 0x5A, n * sizeof(refl_vec3));
        std::vector<uint8_t> stat(n, 0x6B);
        const refl_bounce_stats st = expect_ok<refl_bounce_stats>("bounce band", [&](refl_bounce_stats* s) {
            return refl_bounce_source_rows(s, {out.data(), n, w, h, w}, {stat.data(), n, w, h, w}, &gb, &prev, &bdef,
                                           {2, 5});
        });
        CHECK_EQ(st.reprojected + st.rejected + st.off_screen + st.no_surface, 3 * w);
        CHECK(st.reprojected > 0);
        bool outside = true;
        for (size_t i = 0; i < n; ++i) {
            const size_t row = i / w;
            if (row < 2 || row >= 5) outside = outside && stat[i] == 0x6B && filled(&out[i], sizeof(refl_vec3), 0x5A);
        }
        CHECK(outside);
    }
    struct BArgs {
        refl_image_vec3_mut out;
        refl_image_u8_mut status;
        const refl_gbuffer* gbuffer;
        const refl_bounce_previous* previous;
        const refl_bounce_options* options;
        refl_row_range rows;
    };
    auto bcheck = [&](const char* what, refl_status want, auto edit, bool pointers = false) {
        std::vector<refl_vec3> out(n + 1);
        std::memset(static_cast<void*>(out.data()), 0x5A, out.size() * sizeof(refl_vec3));
        std::vector<uint8_t> stat(n + 1, 0x6B);
        BArgs a{{out.data(), n, w, h, w}, {stat.data(), n, w, h, w}, &gb, &prev, &bdef, all};
        edit(a);
        expect<refl_bounce_stats>(what, want, [&](refl_bounce_stats* st) {
            return refl_bounce_source_rows(st, a.out, a.status, a.gbuffer, a.previous, a.options, a.rows);
        }, pointers);
        if (!filled(out.data(), out.size() * sizeof(refl_vec3), 0x5A) || !filled(stat.data(), stat.size(), 0x6B))
            check::fail(__FILE__, __LINE__, std::string(what) + ": an output was written");
        CHECK(lit[0].x == 0.5f && lit[n - 1].x == 0.5f && last[0].x == 1.0f && last[n - 1].x == 1.0f);
    };
    bcheck("bounce rows reversed (and NULL / misaligned stats)", REFL_STATUS_INVALID_ARGUMENT,
           [](BArgs& a) { a.rows = {3, 2}; }, true);
    bcheck("bounce NULL out", REFL_STATUS_NULL_POINTER, [](BArgs& a) { a.out.data = nullptr; });
    bcheck("bounce NULL gbuffer", REFL_STATUS_NULL_POINTER, [](BArgs& a) { a.gbuffer = nullptr; });
    bcheck("bounce NULL previous", REFL_STATUS_NULL_POINTER, [](BArgs& a) { a.previous = nullptr; });
    bcheck("bounce NULL options", REFL_STATUS_NULL_POINTER, [](BArgs& a) { a.options = nullptr; });
    refl_gbuffer unlit = gb;
    unlit.color = {nullptr, 0, 0, 0, 0};
    bcheck("bounce G-buffer without a lit color", REFL_STATUS_NULL_POINTER, [&](BArgs& a) { a.gbuffer = &unlit; });
    refl_bounce_previous no_color = prev;
    no_color.color.data = nullptr;
    bcheck("bounce NULL previous color", REFL_STATUS_NULL_POINTER, [&](BArgs& a) { a.previous = &no_color; });
    std::vector<refl_bounce_options> bad_b;
    for (float v : {kNaN, -0.01f, 1.01f, kInf}) bad_b.push_back({v, 0.02f});
    for (float v : {kNaN, -0.01f, kInf}) bad_b.push_back({1.0f, v});
    for (const refl_bounce_options& o : bad_b)
        bcheck("bounce bad options", REFL_STATUS_INVALID_ARGUMENT, [&](BArgs& a) { a.options = &o; });
    bcheck("bounce rows past the end", REFL_STATUS_INVALID_ARGUMENT, [&](BArgs& a) { a.rows = {0, h + 1}; });
    bcheck("bounce short out", REFL_STATUS_INSUFFICIENT_SIZE, [&](BArgs& a) { a.out.len = n - 1; });
    bcheck("bounce out of another size", REFL_STATUS_INVALID_ARGUMENT, [&](BArgs& a) { a.out.height = h - 1; });
    bcheck("bounce status of another size", REFL_STATUS_INVALID_ARGUMENT, [&](BArgs& a) { a.status.width = w + 1; });
    bcheck("bounce misaligned out", REFL_STATUS_INVALID_ARGUMENT, [](BArgs& a) {
        a.out.data = reinterpret_cast<refl_vec3*>(reinterpret_cast<char*>(a.out.data) + 1);
    });
    refl_bounce_previous prev_small = prev;
    prev_small.color.height = h - 1;
    bcheck("bounce previous color of another size", REFL_STATUS_INVALID_ARGUMENT,
           [&](BArgs& a) { a.previous = &prev_small; });
    refl_bounce_previous prev_short = prev;
    prev_short.color.len = n - 1;
    bcheck("bounce short previous color", REFL_STATUS_INSUFFICIENT_SIZE, [&](BArgs& a) { a.previous = &prev_short; });
    std::vector<refl_bounce_previous> bad_prev;
    for (uint32_t c : kBadConventions) {
        refl_bounce_previous p = prev;
        p.depth.convention = c;
        bad_prev.push_back(p);
    }
    for (const BadCamera& bc : bad_cameras()) {
        refl_bounce_previous p = prev;
        p.depth.camera = bc.cam;
        bad_prev.push_back(p);
    }
    for (const refl_bounce_previous& p : bad_prev) {
        std::vector<refl_vec3> out(n);
        std::memset(static_cast<void*>(out.data()), 0x5A, n * sizeof(refl_vec3));
        refl_bounce_stats st;
        std::memset(static_cast<void*>(&st), 0x5A, sizeof st);
        const uint32_t got = refl_bounce_source_rows(&st, {out.data(), n, w, h, w}, {nullptr, 0, 0, 0, 0}, &gb, &p,
                                                     &bdef, all);
        CHECK(got != REFL_STATUS_OK);
        CHECK(filled(out.data(), n * sizeof(refl_vec3), 0x5A) && filled(&st, sizeof st, 0x5A));
    }
    bcheck("bounce out over the lit color", REFL_STATUS_INVALID_ARGUMENT, [&](BArgs& a) { a.out.data = lit.data(); });
    bcheck("bounce out over the previous color", REFL_STATUS_INVALID_ARGUMENT,
           [&](BArgs& a) { a.out.data = last.data(); });
    bcheck("bounce status over out", REFL_STATUS_INVALID_ARGUMENT,
           [](BArgs& a) { a.status.data = reinterpret_cast<uint8_t*>(a.out.data) + 12; });

    // --- Extrapolation: texels of the mirror pass (left the image where
    // x is odd, hits elsewhere).
    std::vector<refl_ssr_texel> texels(n);
    for (size_t i = 0; i < n; ++i)
        texels[i] = {(i % 2) ? uint32_t(REFL_SSR_STATUS_LEFT_IMAGE) : uint32_t(REFL_SSR_STATUS_HIT), v2(1.5f, 1.5f),
                     1.0f, 1.0f};
    const refl_extrapolate_options edef = refl_extrapolate_options_default();
    CHECK(edef.radius == 4 && edef.spatial_sigma == 2.0f && !edef.all_host_rays);
    CHECK(REFL_EXTRAPOLATE_MAX_RADIUS == 16);
    {
        std::vector<refl_vec3> out(n);
        std::memset(static_cast<void*>(out.data()), 0x5A, n * sizeof(refl_vec3));
        std::vector<uint8_t> stat(n, 0x6B);
        const refl_extrapolate_stats st = expect_ok<refl_extrapolate_stats>("extrapolate band", [&](refl_extrapolate_stats* s) {
            return refl_extrapolate_fill_rows(s, {out.data(), n, w, h, w}, {stat.data(), n, w, h, w}, nullptr, 0, &gb,
                                              {texels.data(), n, w, h, w}, {lit.data(), n, w, h, w}, &edef, {1, 4});
        });
        CHECK_EQ(st.holes, 3 * (w / 2));
        CHECK_EQ(st.filled, st.holes);
        bool outside = true;
        for (size_t i = 0; i < n; ++i) {
            const size_t row = i / w;
            if (row < 1 || row >= 4) outside = outside && stat[i] == 0x6B && filled(&out[i], sizeof(refl_vec3), 0x5A);
        }
        CHECK(outside);
    }
    struct EArgs {
        refl_image_vec3_mut out;
        refl_image_u8_mut status;
        refl_image_pixel* host;
        size_t host_len;
        const refl_gbuffer* gbuffer;
        refl_image_ssr_texel texels;
        refl_image_vec3 color;
        const refl_extrapolate_options* options;
        refl_row_range rows;
    };
    auto echeck = [&](const char* what, refl_status want, auto edit, bool pointers = false) {
        std::vector<refl_vec3> out(n + 1);
        std::memset(static_cast<void*>(out.data()), 0x5A, out.size() * sizeof(refl_vec3));
        std::vector<uint8_t> stat(n + 1, 0x6B);
        std::vector<refl_image_pixel> host(8);
        std::memset(static_cast<void*>(host.data()), 0x4C, host.size() * sizeof(refl_image_pixel));
        EArgs a{{out.data(), n, w, h, w}, {stat.data(), n, w, h, w}, host.data(), host.size(), &gb,
                {texels.data(), n, w, h, w}, {lit.data(), n, w, h, w}, &edef, all};
        edit(a);
        expect<refl_extrapolate_stats>(what, want, [&](refl_extrapolate_stats* st) {
            return refl_extrapolate_fill_rows(st, a.out, a.status, a.host, a.host_len, a.gbuffer, a.texels, a.color,
                                              a.options, a.rows);
        }, pointers);
        if (!filled(out.data(), out.size() * sizeof(refl_vec3), 0x5A) || !filled(stat.data(), stat.size(), 0x6B) ||
            !filled(host.data(), host.size() * sizeof(refl_image_pixel), 0x4C))
            check::fail(__FILE__, __LINE__, std::string(what) + ": an output was written");
        CHECK(texels[1].status == REFL_SSR_STATUS_LEFT_IMAGE && lit[0].x == 0.5f);
    };
    echeck("extrapolate rows reversed (and NULL / misaligned stats)", REFL_STATUS_INVALID_ARGUMENT,
           [](EArgs& a) { a.rows = {3, 2}; }, true);
    echeck("extrapolate NULL out", REFL_STATUS_NULL_POINTER, [](EArgs& a) { a.out.data = nullptr; });
    echeck("extrapolate NULL host with a length", REFL_STATUS_NULL_POINTER, [](EArgs& a) { a.host = nullptr; });
    echeck("extrapolate NULL gbuffer", REFL_STATUS_NULL_POINTER, [](EArgs& a) { a.gbuffer = nullptr; });
    echeck("extrapolate NULL texels", REFL_STATUS_NULL_POINTER, [](EArgs& a) { a.texels.data = nullptr; });
    echeck("extrapolate NULL color", REFL_STATUS_NULL_POINTER, [](EArgs& a) { a.color.data = nullptr; });
    echeck("extrapolate NULL options", REFL_STATUS_NULL_POINTER, [](EArgs& a) { a.options = nullptr; });
    std::vector<refl_extrapolate_options> bad_e;
    for (uint32_t r : {0u, 17u, kMax}) {
        refl_extrapolate_options o = edef;
        o.radius = r;
        bad_e.push_back(o);
    }
    for (float v : {kNaN, 0.0f, -1.0f}) {
        refl_extrapolate_options o = edef;
        o.spatial_sigma = v;
        bad_e.push_back(o);
        o = edef;
        o.depth_threshold = v;
        bad_e.push_back(o);
        o = edef;
        o.depth_sigma = v;
        bad_e.push_back(o);
    }
    for (float v : {kNaN, kInf, -1.0f}) {
        refl_extrapolate_options o = edef;
        o.normal_power = v;
        bad_e.push_back(o);
        o = edef;
        o.min_roughness = v;
        bad_e.push_back(o);
    }
    for (const refl_extrapolate_options& o : bad_e)
        echeck("extrapolate bad options", REFL_STATUS_INVALID_ARGUMENT, [&](EArgs& a) { a.options = &o; });
    echeck("extrapolate short texels", REFL_STATUS_INSUFFICIENT_SIZE, [&](EArgs& a) { a.texels.len = n - 1; });
    echeck("extrapolate texels of another size", REFL_STATUS_INVALID_ARGUMENT, [&](EArgs& a) { a.texels.width = w - 1; });
    echeck("extrapolate misaligned texels", REFL_STATUS_INVALID_ARGUMENT, [](EArgs& a) {
        a.texels.data = reinterpret_cast<const refl_ssr_texel*>(reinterpret_cast<const char*>(a.texels.data) + 2);
        a.texels.len -= 1;
    });
    std::vector<refl_ssr_texel> bad_texels = texels;
    bad_texels[n - 1].status = 10;
    echeck("extrapolate texel status 10", REFL_STATUS_INVALID_ARGUMENT,
           [&](EArgs& a) { a.texels.data = bad_texels.data(); });
    bad_texels[n - 1].status = kMax;
    echeck("extrapolate texel status kMax", REFL_STATUS_INVALID_ARGUMENT,
           [&](EArgs& a) { a.texels.data = bad_texels.data(); });
    echeck("extrapolate color of another size", REFL_STATUS_INVALID_ARGUMENT, [&](EArgs& a) { a.color.height = h - 1; });
    echeck("extrapolate out of another size", REFL_STATUS_INVALID_ARGUMENT, [&](EArgs& a) { a.out.width = w + 1; });
    echeck("extrapolate short out", REFL_STATUS_INSUFFICIENT_SIZE, [&](EArgs& a) { a.out.len = n - 1; });
    echeck("extrapolate misaligned host", REFL_STATUS_INVALID_ARGUMENT, [](EArgs& a) {
        a.host = reinterpret_cast<refl_image_pixel*>(reinterpret_cast<char*>(a.host) + 1);
        a.host_len = 4;
    });
    echeck("extrapolate out over the color", REFL_STATUS_INVALID_ARGUMENT, [&](EArgs& a) { a.out.data = lit.data(); });
    echeck("extrapolate host over out", REFL_STATUS_INVALID_ARGUMENT,
           [](EArgs& a) { a.host = reinterpret_cast<refl_image_pixel*>(a.out.data + 4); });
    echeck("extrapolate status over the texels", REFL_STATUS_INVALID_ARGUMENT,
           [&](EArgs& a) { a.status.data = reinterpret_cast<uint8_t*>(texels.data()); });

    // --- Upsampling.
    uint32_t hw = 0, hh = 0;
    CHECK_STATUS(refl_upsample_half_size(&hw, &hh, w, h), REFL_STATUS_OK);
    CHECK(hw == (w + 1) / 2 && hh == (h + 1) / 2);
    expect<uint32_t>("upsample half size of a zero width", REFL_STATUS_INVALID_ARGUMENT,
                     [&](uint32_t* o) { return refl_upsample_half_size(o, &hh, 0, h); });
    {
        uint32_t a = 7;
        CHECK_STATUS(refl_upsample_half_size(&a, nullptr, w, h), REFL_STATUS_NULL_POINTER);
        CHECK(a == 7);
    }
    const size_t hn = size_t(hw) * hh;
    const refl_ssr_options so = refl_ssr_options_default();
    const refl_upsample_subsample sub{REFL_UPSAMPLE_PATTERN_STAGGERED, 1};
    std::vector<refl_ssr_texel> half(hn);
    std::vector<refl_vec3> half_color(hn);
    expect_ok<refl_ssr_stats>("upsample trace", [&](refl_ssr_stats* s) {
        return refl_upsample_trace_rows(s, half.data(), hn, {half_color.data(), hn, hw, hh, hw}, nullptr, 0, &gb, &so,
                                        nullptr, 0, &sub, {0, hh});
    });
    struct TArgs {
        refl_ssr_texel* out;
        size_t out_len;
        refl_image_vec3_mut color;
        const refl_ssr_options* ssr;
        const refl_upsample_subsample* sub;
        refl_row_range rows;
    };
    auto tcheck = [&](const char* what, refl_status want, auto edit, bool pointers = false) {
        std::vector<refl_ssr_texel> out(hn + 1);
        std::memset(static_cast<void*>(out.data()), 0x5A, out.size() * sizeof(refl_ssr_texel));
        std::vector<refl_vec3> col(hn + 1);
        std::memset(static_cast<void*>(col.data()), 0x5A, col.size() * sizeof(refl_vec3));
        TArgs a{out.data(), hn, {col.data(), hn, hw, hh, hw}, &so, &sub, {0, hh}};
        edit(a);
        expect<refl_ssr_stats>(what, want, [&](refl_ssr_stats* st) {
            return refl_upsample_trace_rows(st, a.out, a.out_len, a.color, nullptr, 0, &gb, a.ssr, nullptr, 0, a.sub,
                                            a.rows);
        }, pointers);
        if (!filled(out.data(), out.size() * sizeof(refl_ssr_texel), 0x5A) ||
            !filled(col.data(), col.size() * sizeof(refl_vec3), 0x5A))
            check::fail(__FILE__, __LINE__, std::string(what) + ": an output was written");
    };
    tcheck("upsample trace rows past the half height (and NULL / misaligned stats)", REFL_STATUS_INVALID_ARGUMENT,
           [&](TArgs& a) { a.rows = {0, hh + 1}; }, true);
    tcheck("upsample trace NULL out", REFL_STATUS_NULL_POINTER, [](TArgs& a) { a.out = nullptr; });
    tcheck("upsample trace NULL subsample", REFL_STATUS_NULL_POINTER, [](TArgs& a) { a.sub = nullptr; });
    tcheck("upsample trace short out", REFL_STATUS_INSUFFICIENT_SIZE, [&](TArgs& a) { a.out_len = hn - 1; });
    tcheck("upsample trace color of the full size", REFL_STATUS_INVALID_ARGUMENT, [&](TArgs& a) {
        a.color.width = w;
        a.color.height = h;
    });
    const refl_upsample_subsample bad_sub{2, 0};
    tcheck("upsample trace unknown pattern", REFL_STATUS_INVALID_ARGUMENT, [&](TArgs& a) { a.sub = &bad_sub; });
    refl_ssr_options hiz = so;
    hiz.method = REFL_SSR_METHOD_HIZ;
    tcheck("upsample trace Hi-Z without a pyramid", REFL_STATUS_NULL_POINTER, [&](TArgs& a) { a.ssr = &hiz; });

    const refl_upsample_options udef = refl_upsample_options_default();
    CHECK(udef.shade_hits && !udef.retrace && udef.depth_threshold == 0.1f);
    {
        std::vector<refl_ssr_texel> out(n);
        std::memset(static_cast<void*>(out.data()), 0x5A, n * sizeof(refl_ssr_texel));
        std::vector<uint8_t> stat(n, 0x6B);
        const refl_upsample_stats st = expect_ok<refl_upsample_stats>("upsample band", [&](refl_upsample_stats* s) {
            return refl_upsample_resolve_rows(s, out.data(), n, {nullptr, 0, 0, 0, 0}, {stat.data(), n, w, h, w},
                                              nullptr, 0, &gb, &so, nullptr, 0, &sub, {half.data(), hn, hw, hh, hw},
                                              {half_color.data(), hn, hw, hh, hw}, &udef, {2, 6});
        });
        CHECK(st.copied > 0);
        bool outside = true;
        for (size_t i = 0; i < n; ++i) {
            const size_t row = i / w;
            if (row < 2 || row >= 6)
                outside = outside && stat[i] == 0x6B && filled(&out[i], sizeof(refl_ssr_texel), 0x5A);
        }
        CHECK(outside);
    }
    struct UArgs {
        refl_ssr_texel* out;
        size_t out_len;
        refl_image_vec3_mut color;
        refl_image_u8_mut status;
        refl_image_pixel* list;
        size_t list_len;
        const refl_upsample_subsample* sub;
        refl_image_ssr_texel half;
        refl_image_vec3 half_color;
        const refl_upsample_options* options;
        refl_row_range rows;
    };
    auto ucheck = [&](const char* what, refl_status want, auto edit, bool pointers = false) {
        std::vector<refl_ssr_texel> out(n + 1);
        std::memset(static_cast<void*>(out.data()), 0x5A, out.size() * sizeof(refl_ssr_texel));
        std::vector<refl_vec3> col(n + 1);
        std::memset(static_cast<void*>(col.data()), 0x5A, col.size() * sizeof(refl_vec3));
        std::vector<uint8_t> stat(n + 1, 0x6B);
        std::vector<refl_image_pixel> list(8);
        std::memset(static_cast<void*>(list.data()), 0x4C, list.size() * sizeof(refl_image_pixel));
        UArgs a{out.data(), n, {col.data(), n, w, h, w}, {stat.data(), n, w, h, w}, list.data(), list.size(), &sub,
                {half.data(), hn, hw, hh, hw}, {half_color.data(), hn, hw, hh, hw}, &udef, all};
        edit(a);
        expect<refl_upsample_stats>(what, want, [&](refl_upsample_stats* st) {
            return refl_upsample_resolve_rows(st, a.out, a.out_len, a.color, a.status, a.list, a.list_len, &gb, &so,
                                              nullptr, 0, a.sub, a.half, a.half_color, a.options, a.rows);
        }, pointers);
        if (!filled(out.data(), out.size() * sizeof(refl_ssr_texel), 0x5A) ||
            !filled(col.data(), col.size() * sizeof(refl_vec3), 0x5A) || !filled(stat.data(), stat.size(), 0x6B) ||
            !filled(list.data(), list.size() * sizeof(refl_image_pixel), 0x4C))
            check::fail(__FILE__, __LINE__, std::string(what) + ": an output was written");
    };
    ucheck("upsample rows reversed (and NULL / misaligned stats)", REFL_STATUS_INVALID_ARGUMENT,
           [](UArgs& a) { a.rows = {3, 2}; }, true);
    ucheck("upsample NULL out", REFL_STATUS_NULL_POINTER, [](UArgs& a) { a.out = nullptr; });
    ucheck("upsample NULL list with a length", REFL_STATUS_NULL_POINTER, [](UArgs& a) { a.list = nullptr; });
    ucheck("upsample NULL subsample", REFL_STATUS_NULL_POINTER, [](UArgs& a) { a.sub = nullptr; });
    ucheck("upsample NULL half", REFL_STATUS_NULL_POINTER, [](UArgs& a) { a.half.data = nullptr; });
    ucheck("upsample NULL options", REFL_STATUS_NULL_POINTER, [](UArgs& a) { a.options = nullptr; });
    std::vector<refl_upsample_options> bad_u;
    for (float v : {kNaN, 0.0f, -1.0f}) {
        refl_upsample_options o = udef;
        o.depth_threshold = v;
        bad_u.push_back(o);
        o = udef;
        o.depth_sigma = v;
        bad_u.push_back(o);
    }
    for (float v : {kNaN, kInf, -1.0f}) {
        refl_upsample_options o = udef;
        o.normal_power = v;
        bad_u.push_back(o);
    }
    for (const refl_upsample_options& o : bad_u)
        ucheck("upsample bad options", REFL_STATUS_INVALID_ARGUMENT, [&](UArgs& a) { a.options = &o; });
    ucheck("upsample unknown pattern", REFL_STATUS_INVALID_ARGUMENT, [&](UArgs& a) { a.sub = &bad_sub; });
    ucheck("upsample rows past the end", REFL_STATUS_INVALID_ARGUMENT, [&](UArgs& a) { a.rows = {0, h + 1}; });
    ucheck("upsample short out", REFL_STATUS_INSUFFICIENT_SIZE, [&](UArgs& a) { a.out_len = n - 1; });
    ucheck("upsample half of the full size", REFL_STATUS_INVALID_ARGUMENT, [&](UArgs& a) {
        a.half = {texels.data(), n, w, h, w};
    });
    ucheck("upsample short half", REFL_STATUS_INSUFFICIENT_SIZE, [&](UArgs& a) { a.half.len = hn - 1; });
    std::vector<refl_ssr_texel> bad_half = half;
    bad_half[0].status = 0x100;
    ucheck("upsample half texel status 256", REFL_STATUS_INVALID_ARGUMENT, [&](UArgs& a) { a.half.data = bad_half.data(); });
    ucheck("upsample half color of another size", REFL_STATUS_INVALID_ARGUMENT,
           [&](UArgs& a) { a.half_color.height = hh - 1; });
    ucheck("upsample color without half color", REFL_STATUS_INVALID_ARGUMENT,
           [](UArgs& a) { a.half_color = {nullptr, 0, 0, 0, 0}; });
    ucheck("upsample status of another size", REFL_STATUS_INVALID_ARGUMENT, [&](UArgs& a) { a.status.width = w - 1; });
    ucheck("upsample status over half", REFL_STATUS_INVALID_ARGUMENT,
           [&](UArgs& a) { a.status.data = reinterpret_cast<uint8_t*>(half.data()); });
    ucheck("upsample status over out", REFL_STATUS_INVALID_ARGUMENT,
           [](UArgs& a) { a.status.data = reinterpret_cast<uint8_t*>(a.out) + 4; });
    ucheck("upsample out over half", REFL_STATUS_INVALID_ARGUMENT, [&](UArgs& a) {
        a.out = half.data();
        a.out_len = n;
    });
    ucheck("upsample list over out", REFL_STATUS_INVALID_ARGUMENT,
           [](UArgs& a) { a.list = reinterpret_cast<refl_image_pixel*>(a.out + 2); });
}


// The frame summary and the pass plan (issue 15): every export, its
// refusals with outputs untouched.
void summary_functions() {
    const refl_camera cam = good_camera();
    const uint32_t w = cam.width, h = cam.height;
    const size_t n = size_t(w) * h;
    std::vector<float> depth(n, 0.5f);
    std::vector<refl_vec3> normals(n, v3(0, 1, 0));
    std::vector<uint32_t> ids(n, 0u);
    const refl_gbuffer gb = plain_gbuffer(cam, depth, normals);
    const refl_summary_options def = refl_summary_options_default();
    CHECK(def.mirror_roughness == 0.1f && def.glossy_roughness == 1.0f && def.border_pixels == REFL_SUMMARY_TILE);
    const refl_image_u32 idimg{ids.data(), n, w, h, w};
    const refl_row_range all{0, h};
    refl_summary_object objs[2] = {};
    const refl_summary_frame frame = expect_ok<refl_summary_frame>(
        "summary", [&](refl_summary_frame* f) { return refl_summary_rows(f, objs, 2, &gb, idimg, &def, all); });
    CHECK_EQ(frame.pixels, uint64_t(n));
    CHECK_EQ(objs[0].pixels, frame.reflective);
    refl_summary_object scratch_objs[2] = {};
    auto rows_call = [&](const char* what, refl_status want, const refl_gbuffer* g, refl_image_u32 im,
                         const refl_summary_options* o, refl_row_range r, size_t k, refl_summary_object* op) {
        expect<refl_summary_frame>(what, want, [&](refl_summary_frame* f) {
            return refl_summary_rows(f, op, k, g, im, o, r);
        });
    };
    refl_summary_options bad = def;
    bad.normal_cos = kNaN;
    refl_image_u32 short_ids = idimg;
    short_ids.width -= 1;
    rows_call("summary NULL gbuffer", REFL_STATUS_NULL_POINTER, nullptr, idimg, &def, all, 2, scratch_objs);
    rows_call("summary NULL options", REFL_STATUS_NULL_POINTER, &gb, idimg, nullptr, all, 2, scratch_objs);
    rows_call("summary NULL objects", REFL_STATUS_NULL_POINTER, &gb, idimg, &def, all, 2, nullptr);
    rows_call("summary options NaN", REFL_STATUS_INVALID_ARGUMENT, &gb, idimg, &bad, all, 2, scratch_objs);
    rows_call("summary rows off a tile row", REFL_STATUS_INVALID_ARGUMENT, &gb, idimg, &def, refl_row_range{3, h}, 2,
              scratch_objs);
    rows_call("summary ids of another size", REFL_STATUS_INVALID_ARGUMENT, &gb, short_ids, &def, all, 2, scratch_objs);
    rows_call("summary no objects", REFL_STATUS_INSUFFICIENT_SIZE, &gb, idimg, &def, all, 0, scratch_objs);
    for (const refl_summary_object& o : scratch_objs) CHECK_EQ(o.pixels, uint64_t(0));

    // Merges and the plane fit.
    const refl_summary_frame twice = expect_ok<refl_summary_frame>("merge frame", [&](refl_summary_frame* d) {
        *d = frame;
        return refl_summary_merge_frame(d, &frame);
    });
    CHECK_EQ(twice.pixels, 2 * uint64_t(n));
    expect<refl_summary_frame>("merge frame NULL src", REFL_STATUS_NULL_POINTER,
                               [&](refl_summary_frame* d) { return refl_summary_merge_frame(d, nullptr); });
    const refl_summary_object both = expect_ok<refl_summary_object>("merge object", [&](refl_summary_object* d) {
        *d = objs[0];
        return refl_summary_merge_object(d, &objs[0]);
    });
    CHECK_EQ(both.pixels, 2 * objs[0].pixels);
    expect<refl_summary_object>("merge object NULL src", REFL_STATUS_NULL_POINTER,
                                [&](refl_summary_object* d) { return refl_summary_merge_object(d, nullptr); });
    const refl_summary_plane_fit fit = expect_ok<refl_summary_plane_fit>(
        "plane", [&](refl_summary_plane_fit* p) { return refl_summary_object_plane(p, &objs[0], &def); });
    CHECK(std::fabs(fit.normal[1] - 1.0) < 1e-9 && fit.coherence > 0.999);
    expect<refl_summary_plane_fit>("plane of an empty object", REFL_STATUS_DEGENERATE_GEOMETRY,
                                   [&](refl_summary_plane_fit* p) { return refl_summary_object_plane(p, &objs[1], &def); });
    expect<refl_summary_plane_fit>("plane options NaN", REFL_STATUS_INVALID_ARGUMENT,
                                   [&](refl_summary_plane_fit* p) { return refl_summary_object_plane(p, &objs[0], &bad); });

    // The plan.
    const refl_plan_options po = refl_plan_options_default();
    CHECK(po.mirror_hiz && po.glossy_visibility);
    const refl_plan_host_caps caps{true, true, true};
    bool planar[2] = {false, false};
    const refl_plan plan = expect_ok<refl_plan>("plan", [&](refl_plan* p) {
        return refl_plan_passes(p, planar, 2, &frame, objs, 2, nullptr, 0, &caps, &def, &po, w, h);
    });
    for (size_t k = 0; k < REFL_PLAN_PASS_COUNT; ++k) {
        CHECK_EQ(plan.passes[k].pass, uint32_t(k));
        CHECK(plan.passes[k].reason == REFL_PLAN_REASON_RUNS || plan.passes[k].bytes == 0);
    }
    const refl_plan_object_hints one_hint[1] = {{true, false, false}};
    auto plan_call = [&](const char* what, refl_status want, size_t planar_len, const refl_plan_object_hints* hints,
                         size_t hints_len, uint32_t width) {
        bool pl[2] = {true, true};
        expect<refl_plan>(what, want, [&](refl_plan* p) {
            return refl_plan_passes(p, pl, planar_len, &frame, objs, 2, hints, hints_len, &caps, &def, &po, width, h);
        });
        CHECK(pl[0] && pl[1]);
    };
    plan_call("plan planar too short", REFL_STATUS_INSUFFICIENT_SIZE, 1, nullptr, 0, w);
    plan_call("plan hints of another count", REFL_STATUS_INVALID_ARGUMENT, 2, one_hint, 1, w);
    plan_call("plan hints NULL", REFL_STATUS_NULL_POINTER, 2, nullptr, 2, w);
    plan_call("plan zero width", REFL_STATUS_INVALID_ARGUMENT, 2, nullptr, 0, 0);

    // Method choice by budget: a mirror option by rays, one by the probe.
    size_t nchoices = 0;
    CHECK_STATUS(refl_plan_choices_len(&nchoices, 2), REFL_STATUS_OK);
    CHECK_EQ(nchoices, size_t(9));
    CHECK_STATUS(refl_plan_choices_len(nullptr, 2), REFL_STATUS_NULL_POINTER);
    const refl_plan_cost_entry table[3] = {
        {1, 0, REFL_PLAN_SURFACE_ANY, 1u << REFL_PLAN_PASS_HOST_RAYS, 1.0f, 0.0f},
        {2, 0, REFL_PLAN_SURFACE_ANY, 1u << REFL_PLAN_PASS_PROBE, 0.05f, 30.0f},
        {3, 1, REFL_PLAN_SURFACE_ANY, 1u << REFL_PLAN_PASS_PROBE, 0.05f, 20.0f},
    };
    const refl_plan_budget budget{REFL_PLAN_BUDGET_KIND_MAX_ERROR, 5.0f};
    const bool flat[2] = {false, false};
    std::vector<refl_plan_choice> choices(nchoices);
    const refl_plan_budget_plan bp = expect_ok<refl_plan_budget_plan>("choose", [&](refl_plan_budget_plan* p) {
        return refl_plan_choose_methods(p, choices.data(), choices.size(), &frame, objs, 2, flat, 2, nullptr, 0,
                                        &caps, table, 3, &budget);
    });
    CHECK(bp.groups <= choices.size() && bp.covered <= bp.reflective);
    for (size_t k = 0; k < bp.groups; ++k)
        CHECK(choices[k].entry == REFL_PLAN_NO_ENTRY || choices[k].entry < 3);
    refl_plan_cost_entry bad_table[3] = {table[0], table[1], table[2]};
    bad_table[1].time_ratio = kNaN;
    refl_plan_cost_entry bad_class[3] = {table[0], table[1], table[2]};
    bad_class[2].roughness_class = 9;
    const refl_plan_budget nan_budget{REFL_PLAN_BUDGET_KIND_MAX_TIME, kNaN};
    const refl_plan_budget bad_kind{7, 1.0f};
    auto choose_call = [&](const char* what, refl_status want, size_t choices_len, const bool* pl, size_t planar_len,
                           const refl_plan_object_hints* hints, size_t hints_len, const refl_plan_cost_entry* t,
                           size_t table_len, const refl_plan_budget* b) {
        std::vector<refl_plan_choice> cs(nchoices);
        std::memset(cs.data(), 0x5A, cs.size() * sizeof(refl_plan_choice));
        std::vector<unsigned char> before(cs.size() * sizeof(refl_plan_choice), 0x5A);
        expect<refl_plan_budget_plan>(what, want, [&](refl_plan_budget_plan* p) {
            return refl_plan_choose_methods(p, cs.data(), choices_len, &frame, objs, 2, pl, planar_len, hints,
                                            hints_len, &caps, t, table_len, b);
        });
        CHECK(std::memcmp(cs.data(), before.data(), before.size()) == 0);
    };
    const size_t nc = choices.size();
    choose_call("choose NULL budget", REFL_STATUS_NULL_POINTER, nc, flat, 2, nullptr, 0, table, 3, nullptr);
    choose_call("choose NULL table", REFL_STATUS_NULL_POINTER, nc, flat, 2, nullptr, 0, nullptr, 3, &budget);
    choose_call("choose NULL planar", REFL_STATUS_NULL_POINTER, nc, nullptr, 2, nullptr, 0, table, 3, &budget);
    choose_call("choose NULL hints", REFL_STATUS_NULL_POINTER, nc, flat, 2, nullptr, 2, table, 3, &budget);
    choose_call("choose NaN budget", REFL_STATUS_INVALID_ARGUMENT, nc, flat, 2, nullptr, 0, table, 3, &nan_budget);
    choose_call("choose unknown budget kind", REFL_STATUS_INVALID_ARGUMENT, nc, flat, 2, nullptr, 0, table, 3,
                &bad_kind);
    choose_call("choose NaN table time", REFL_STATUS_INVALID_ARGUMENT, nc, flat, 2, nullptr, 0, bad_table, 3,
                &budget);
    choose_call("choose unknown class", REFL_STATUS_INVALID_ARGUMENT, nc, flat, 2, nullptr, 0, bad_class, 3,
                &budget);
    choose_call("choose hints of another count", REFL_STATUS_INVALID_ARGUMENT, nc, flat, 2, one_hint, 1, table, 3,
                &budget);
    choose_call("choose planar too short", REFL_STATUS_INVALID_ARGUMENT, nc, flat, 1, nullptr, 0, table, 3, &budget);
    if (bp.groups > 0)
        choose_call("choose choices too short", REFL_STATUS_INSUFFICIENT_SIZE, bp.groups - 1, flat, 2, nullptr, 0,
                    table, 3, &budget);
    choose_call("choose huge table_len", REFL_STATUS_INVALID_ARGUMENT, nc, flat, 2, nullptr, 0, table, SIZE_MAX,
                &budget);
}

int main() {
    status_strings();
    camera_functions();
    plane_functions();
    image_functions();
    epipolar_functions();
    step_functions();
    layered_functions();
    refine_functions();
    hiz_functions();
    tcrr_functions();
    cluster_functions();
    cone_functions();
    ssr_functions();
    glossy_functions();
    planar_functions();
    cluster_pass_functions();
    layered_pass_functions();
    summary_functions();
    temporal_functions();
    bounce_extrapolate_upsample_functions();
    return check::finish("hostile_input");
}
