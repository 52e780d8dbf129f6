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

// Seed 002 (reprojected ray casting): params, scratch size, reprojection,
// decisions per row range.
void epipolar_functions() {
    const refl_camera g = good_camera();  // 64 x 48
    const uint32_t w = g.width, h = g.height;
    const size_t n = size_t(w) * h;

    const refl_epipolar_params p =
        expect_ok<refl_epipolar_params>("epipolar_params_default", [](refl_epipolar_params* o) {
            return refl_epipolar_params_default(o);
        });
    CHECK(p.m_cnt == 5 && p.splat_radius == 1 && p.resample_period == 9);
    CHECK_STATUS(refl_epipolar_params_default(nullptr), REFL_STATUS_NULL_POINTER);

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
                   const refl_camera* prev, const refl_camera* cur, const refl_epipolar_params* par) {
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
    std::vector<refl_epipolar_params> bad_params;
    auto bad_param = [&](auto edit) {
        refl_epipolar_params q = p;
        edit(q);
        bad_params.push_back(q);
    };
    bad_param([](refl_epipolar_params& q) { q.m_cnt = 0; });
    bad_param([](refl_epipolar_params& q) { q.splat_radius = REFL_EPIPOLAR_MAX_SPLAT_RADIUS + 1; });
    bad_param([](refl_epipolar_params& q) { q.splat_radius = kMax; });
    bad_param([](refl_epipolar_params& q) { q.depth_guard = 2; });
    bad_param([](refl_epipolar_params& q) { q.frustum_check = kMax; });
    bad_param([](refl_epipolar_params& q) { q.occlusion_check = 0x80000000u; });
    bad_param([](refl_epipolar_params& q) { q.shift_origin = 3; });
    bad_param([](refl_epipolar_params& q) { q.shift_epsilon = kNaN; });
    bad_param([](refl_epipolar_params& q) { q.shift_epsilon = kInf; });
    bad_param([](refl_epipolar_params& q) { q.shift_epsilon = -1.0f; });
    bad_param([](refl_epipolar_params& q) { q.guard_margin = kNaN; });
    bad_param([](refl_epipolar_params& q) { q.guard_window = REFL_EPIPOLAR_MAX_SPLAT_RADIUS + 1; });
    bad_param([](refl_epipolar_params& q) { q.guard_margin = 1.0f; });
    bad_param([](refl_epipolar_params& q) { q.guard_margin = -0.5f; });
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
                   uint32_t e, const refl_epipolar_params* par) {
        return [=](refl_epipolar_decision* o) {
            return refl_epipolar_decide_rows(o, out_len, a, aip_len, width, b, e, 0, par);
        };
    };
    {
        std::vector<refl_epipolar_decision> out(n, dsent);
        CHECK_STATUS(refl_epipolar_decide_rows(out.data(), n, aip.data(), n, w, 1, 3, 0, &p), REFL_STATUS_OK);
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
                                         0, h, 0, &p);
    });
}

}  // namespace

int main() {
    status_strings();
    camera_functions();
    plane_functions();
    image_functions();
    epipolar_functions();
    return check::finish("hostile_input");
}
