// hostile_input: every exported refl function, called with NULL pointers,
// zero and overflowing sizes, short buffers, misaligned pointers, NaN/Inf
// parameters, invalid cameras and planes and unknown enum values. Each call
// must return its documented status and leave its outputs byte-identical
// (outputs are prefilled with a sentinel pattern and compared after).
#include <cmath>
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
        auto f1 = [&](refl_mat4* o) { return refl_reprojection_matrix(o, c, &g, REFL_DEPTH_CONVENTION_ZERO_TO_ONE); };
        auto f2 = [&](refl_mat4* o) { return refl_reprojection_matrix(o, &g, c, REFL_DEPTH_CONVENTION_REVERSED_Z); };
        if (okay) {
            expect_ok<refl_mat4>(n, f1);
            expect_ok<refl_mat4>(n, f2);
        } else {
            expect<refl_mat4>(n, st, f1);
            expect<refl_mat4>(n, st, f2);
        }
    });
    per_camera("reproject", [&](const refl_camera* c, refl_status st, const char* n, bool okay) {
        auto f1 = [&](refl_projection* o) { return refl_reproject(o, c, &g, px, 0.5f, REFL_DEPTH_CONVENTION_ZERO_TO_ONE); };
        auto f2 = [&](refl_projection* o) { return refl_reproject(o, &g, c, px, 3.0f, REFL_DEPTH_CONVENTION_LINEAR); };
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
                                [&](refl_projection* o) { return refl_reproject(o, &g, &g, b, 0.5f, 1); });
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
                                [&](refl_projection* o) { return refl_reproject(o, &g, &g, px, d, 0); });
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
                          [&](refl_mat4* o) { return refl_reprojection_matrix(o, &g, &g, c); });
        expect<refl_projection>("reproject convention", REFL_STATUS_INVALID_ARGUMENT,
                                [&](refl_projection* o) { return refl_reproject(o, &g, &g, px, 0.5f, c); });
    }
    // LINEAR is not projective.
    expect<refl_mat4>("projection LINEAR", REFL_STATUS_INVALID_ARGUMENT,
                      [&](refl_mat4* o) { return refl_camera_projection_matrix(o, &g, REFL_DEPTH_CONVENTION_LINEAR); });
    expect<refl_mat4>("world_to_pixel LINEAR", REFL_STATUS_INVALID_ARGUMENT, [&](refl_mat4* o) {
        return refl_camera_world_to_pixel_matrix(o, &g, REFL_DEPTH_CONVENTION_LINEAR);
    });
    expect<refl_mat4>("reprojection LINEAR", REFL_STATUS_INVALID_ARGUMENT, [&](refl_mat4* o) {
        return refl_reprojection_matrix(o, &g, &g, REFL_DEPTH_CONVENTION_LINEAR);
    });
    // The far plane at infinity has no finite point.
    refl_camera inf_far = g;
    inf_far.z_far = kInf;
    expect<refl_vec3>("unproject infinite far", REFL_STATUS_INVALID_ARGUMENT, [&](refl_vec3* o) {
        return refl_camera_unproject(o, &inf_far, px, 0.0f, REFL_DEPTH_CONVENTION_REVERSED_Z);
    });

    // refl_apply_reprojection
    const refl_mat4 m = expect_ok<refl_mat4>("reprojection_matrix", [&](refl_mat4* o) {
        return refl_reprojection_matrix(o, &g, &g, REFL_DEPTH_CONVENTION_ZERO_TO_ONE);
    });
    expect_ok<refl_projection>("apply", [&](refl_projection* o) { return refl_apply_reprojection(o, &m, px, 0.5f); });
    expect<refl_projection>("apply NULL matrix", REFL_STATUS_NULL_POINTER,
                            [&](refl_projection* o) { return refl_apply_reprojection(o, nullptr, px, 0.5f); });
    for (int i = 0; i < 16; i += 5) {
        refl_mat4 bm = m;
        bm.m[i] = (i % 2) ? kInf : kNaN;
        expect<refl_projection>("apply bad matrix", REFL_STATUS_INVALID_ARGUMENT,
                                [&](refl_projection* o) { return refl_apply_reprojection(o, &bm, px, 0.5f); });
    }
    for (refl_vec2 b : kBadVec2)
        expect<refl_projection>("apply pixel", REFL_STATUS_INVALID_ARGUMENT,
                                [&](refl_projection* o) { return refl_apply_reprojection(o, &m, b, 0.5f); });
    for (float d : {kNaN, kInf})
        expect<refl_projection>("apply depth", REFL_STATUS_INVALID_ARGUMENT,
                                [&](refl_projection* o) { return refl_apply_reprojection(o, &m, px, d); });
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
                          [&](refl_vec3* o) { return refl_reflect(o, b, v3(0, 1, 0)); });
        expect<refl_vec3>("reflect n", REFL_STATUS_INVALID_ARGUMENT,
                          [&](refl_vec3* o) { return refl_reflect(o, v3(0, 1, 0), b); });
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
                      [&](refl_vec3* o) { return refl_reflect(o, v3(3e38f, 3e38f, 0), v3(1, 1, 0)); });
    expect_ok<refl_vec3>("reflect", [&](refl_vec3* o) { return refl_reflect(o, v3(0, 1, 0), v3(0, 1, 0)); });

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
        auto f = [&](refl_camera* o) { return refl_mirrored_camera(o, &g, pl); };
        if (st == REFL_STATUS_OK) expect_ok<refl_camera>(n, f);
        else expect<refl_camera>(n, st, f);
    });
    for (const BadCamera& b : bad_cameras())
        expect<refl_camera>(b.name, b.status, [&](refl_camera* o) { return refl_mirrored_camera(o, &b.cam, &good); });
    expect<refl_camera>("mirrored NULL camera", REFL_STATUS_NULL_POINTER,
                        [&](refl_camera* o) { return refl_mirrored_camera(o, nullptr, &good); });
    // Oblique near plane: the mirrored camera with the mirror plane is valid;
    // the real camera has its eye on the kept side.
    refl_camera mirrored;
    REQUIRE(refl_mirrored_camera(&mirrored, &g, &good) == REFL_STATUS_OK);
    per_plane("oblique_projection", [&](const refl_plane* pl, refl_status st, const char* n) {
        auto f = [&](refl_mat4* o) {
            return refl_oblique_projection(o, &mirrored, pl, REFL_DEPTH_CONVENTION_REVERSED_Z);
        };
        if (st == REFL_STATUS_OK) expect_ok<refl_mat4>(n, f);
        else expect<refl_mat4>(n, st, f);
    });
    for (const BadCamera& b : bad_cameras())
        expect<refl_mat4>(b.name, b.status, [&](refl_mat4* o) {
            return refl_oblique_projection(o, &b.cam, &good, REFL_DEPTH_CONVENTION_ZERO_TO_ONE);
        });
    expect<refl_mat4>("oblique NULL camera", REFL_STATUS_NULL_POINTER, [&](refl_mat4* o) {
        return refl_oblique_projection(o, nullptr, &good, REFL_DEPTH_CONVENTION_ZERO_TO_ONE);
    });
    for (uint32_t c : {uint32_t(REFL_DEPTH_CONVENTION_LINEAR), 3u, 0xFFFFFFFFu})
        expect<refl_mat4>("oblique convention", REFL_STATUS_INVALID_ARGUMENT,
                          [&](refl_mat4* o) { return refl_oblique_projection(o, &mirrored, &good, c); });
    expect<refl_mat4>("oblique eye on the kept side", REFL_STATUS_DEGENERATE_GEOMETRY, [&](refl_mat4* o) {
        return refl_oblique_projection(o, &g, &good, REFL_DEPTH_CONVENTION_ZERO_TO_ONE);
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
                        [&](refl_camera* o) { return refl_mirrored_camera(o, &far_cam, &offset); });
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

    // refl_row_band
    const refl_row_range band =
        expect_ok<refl_row_range>("row_band", [](refl_row_range* o) { return refl_row_band(o, 10, 3, 4); });
    CHECK(band.begin == 8 && band.end == 10);
    const refl_row_range empty =
        expect_ok<refl_row_range>("row_band empty", [](refl_row_range* o) { return refl_row_band(o, 2, 3, 4); });
    CHECK(empty.begin == empty.end);
    const uint32_t bad_bands[][3] = {{0, 0, 1}, {4, 0, 0}, {4, 1, 1}, {4, kMax, kMax}, {kMax, 5, 5}};
    for (const auto& b : bad_bands)
        expect<refl_row_range>("row_band bad", REFL_STATUS_INVALID_ARGUMENT,
                               [&](refl_row_range* o) { return refl_row_band(o, b[0], b[1], b[2]); });

    // refl_convert_depth: dst is the output; it must stay untouched on error.
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
        return [=](refl_image_f32_mut d) { return refl_convert_depth(d, s, c, from, to, b, e); };
    };
    {
        Buffer dst(64);
        const refl_image_f32_mut d{dst.data.data(), len, w, h, stride};
        CHECK_STATUS(refl_convert_depth(d, src, &g, 0, 1, 1, 3), REFL_STATUS_OK);
        CHECK(!dst.untouched());
        CHECK(dst.data[stride - 1] == -1000.0f - float(stride - 1));  // padding untouched
        CHECK(dst.data[0] == -1000.0f);                                // row 0 outside the range
    }
    run("NULL camera", REFL_STATUS_NULL_POINTER, conv(src, nullptr, 0, 1, 0, h));
    run("NULL src", REFL_STATUS_NULL_POINTER, conv(refl_image_f32{nullptr, len, w, h, stride}, &g, 0, 1, 0, h));
    run("NULL dst", REFL_STATUS_NULL_POINTER, [&](refl_image_f32_mut d) {
        d.data = nullptr;
        return refl_convert_depth(d, src, &g, 0, 1, 0, h);
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
            return refl_convert_depth(d, src, &g, 0, 1, 0, h);
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
        return refl_convert_depth(d, refl_image_f32{d.data + 1, len, w, h, stride}, &g, 0, 1, 0, h);
    });
    run("same memory, other stride", REFL_STATUS_INVALID_ARGUMENT, [&](refl_image_f32_mut d) {
        return refl_convert_depth(d, refl_image_f32{d.data, 64, w, h, stride + 1}, &g, 0, 1, 0, h);
    });
    // In place is allowed.
    {
        Buffer dst(64);
        const refl_image_f32_mut d{dst.data.data(), len, w, h, stride};
        for (size_t i = 0; i < len; ++i) dst.data[i] = 2.0f;
        CHECK_STATUS(refl_convert_depth(d, refl_image_f32{d.data, d.len, w, h, stride}, &g,
                                        REFL_DEPTH_CONVENTION_LINEAR, REFL_DEPTH_CONVENTION_LINEAR, 0, h),
                     REFL_STATUS_OK);
        CHECK_EQ(dst.data[0], 2.0f);
    }
}


// TCRR (seed 000): the scalar exports with NULL/NaN/unknown enums, and the
// passes with NULL data, short buffers, bad conventions, bad parameters and
// bad row ranges; image outputs must stay byte-identical on every error.
void tcrr_functions() {
    // Scalars.
    const refl_tcrr_params dp =
        expect_ok<refl_tcrr_params>("tcrr default params", [](refl_tcrr_params* o) { return refl_tcrr_default_params(o); });
    CHECK_EQ(dp.max_iterations, 64u);
    expect<refl_tcrr_params>("tcrr default params NULL", REFL_STATUS_NULL_POINTER,
                             [](refl_tcrr_params*) { return refl_tcrr_default_params(nullptr); }, false);
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
    CHECK_EQ(expect_ok<uint32_t>("tcrr key frame", [](uint32_t* o) { return refl_tcrr_needs_key_frame(o, 0.3f, 31, 100); }),
             1u);
    for (float t : {kNaN, -0.1f, 1.5f, kInf})
        expect<uint32_t>("tcrr key frame threshold", REFL_STATUS_INVALID_ARGUMENT,
                         [&](uint32_t* o) { return refl_tcrr_needs_key_frame(o, t, 1, 2); });
    expect<uint32_t>("tcrr key frame retrace > reflective", REFL_STATUS_INVALID_ARGUMENT,
                     [](uint32_t* o) { return refl_tcrr_needs_key_frame(o, 0.3f, 3, 2); });

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
    std::vector<refl_tcrr_params> bad_params;
    auto bad_param = [&](auto edit) {
        refl_tcrr_params p = dp;
        edit(p);
        bad_params.push_back(p);
    };
    bad_param([](refl_tcrr_params& p) { p.max_iterations = 0; });
    bad_param([](refl_tcrr_params& p) { p.magnification = kNaN; });
    bad_param([](refl_tcrr_params& p) { p.magnification = 0.5f; });
    bad_param([](refl_tcrr_params& p) { p.discontinuity = -1.0f; });
    bad_param([](refl_tcrr_params& p) { p.reflected_discontinuity = kInf; });
    bad_param([](refl_tcrr_params& p) { p.subpixel = 2; });
    bad_param([](refl_tcrr_params& p) { p.retrace_contrast = kNaN; });
    bad_param([](refl_tcrr_params& p) { p.retrace_contrast = 0.0f; });

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
        auto search = [&](refl_image_vec2_mut o, const refl_tcrr_key* k, refl_vec3 e, const refl_tcrr_params* p,
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
        for (const refl_tcrr_params& p : bad_params)
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
                         refl_image_vec2 o, const refl_tcrr_params* p, refl_row_range rr) {
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
        for (const refl_tcrr_params& p : bad_params)
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
                        const refl_tcrr_key* k, refl_image_u8 cv, const refl_tcrr_params* p, refl_row_range rr) {
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
        for (const refl_tcrr_params& p : bad_params)
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

}  // namespace

int main() {
    status_strings();
    camera_functions();
    plane_functions();
    image_functions();
    tcrr_functions();
    return check::finish("hostile_input");
}
