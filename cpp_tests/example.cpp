// example.cpp: using refl from C++ (the README shows this file).
//
// Builds a camera, the plane of a mirror triangle, the mirrored camera of
// that plane, and prints the primary ray of both cameras through one pixel:
// tracing the mirrored camera's ray from the mirror plane on renders the
// planar reflection.
#include <cstdio>

#include "refl.h"

// Every refl function returns a refl_status; REFL_STATUS_OK is 0 and the
// outputs are written only then.
static bool ok(refl_status s, const char* what) {
    if (s != REFL_STATUS_OK) std::fprintf(stderr, "%s: %s\n", what, refl_status_string(s));
    return s == REFL_STATUS_OK;
}

// For printing: turns -0 into 0.
static double p(float v) { return double(v) + 0.0; }

int main() {
    std::printf("refl %s\n", refl_version());

    // A 640x480 camera at (1, 2, 6) looking at the origin, 60 degrees
    // vertical field of view, near 0.1, far 100.
    refl_camera camera;
    if (!ok(refl_camera_look_at(&camera, refl_vec3{1.0f, 2.0f, 6.0f}, refl_vec3{0.0f, 0.0f, 0.0f},
                                refl_vec3{0.0f, 1.0f, 0.0f}, 1.0471976f, 0.1f, 100.0f, 640, 480),
            "refl_camera_look_at"))
        return 1;

    // The floor y = 0 is a mirror; its plane from one of its triangles.
    refl_plane mirror;
    if (!ok(refl_plane_from_triangle(&mirror, refl_vec3{-5.0f, 0.0f, -5.0f}, refl_vec3{5.0f, 0.0f, -5.0f},
                                     refl_vec3{5.0f, 0.0f, 5.0f}),
            "refl_plane_from_triangle"))
        return 1;
    std::printf("mirror plane: normal (%g, %g, %g), d = %g\n", p(mirror.normal.x), p(mirror.normal.y),
                p(mirror.normal.z), p(mirror.d));

    // The camera mirrored in that plane.
    refl_camera virtual_camera;
    if (!ok(refl_mirror_camera(&virtual_camera, &camera, &mirror), "refl_mirror_camera")) return 1;
    bool flipped = false;
    refl_camera_is_mirrored(&flipped, &virtual_camera);
    std::printf("mirrored camera: flip the front-face test: %s\n", flipped ? "yes" : "no");

    // The ray through the center of pixel (320, 400), which sees the floor.
    const refl_vec2 pixel{320.5f, 400.5f};
    refl_ray primary, reflected;
    if (!ok(refl_camera_primary_ray(&primary, &camera, pixel), "primary ray") ||
        !ok(refl_camera_primary_ray(&reflected, &virtual_camera, pixel), "mirrored ray"))
        return 1;
    // Start the mirrored ray at the mirror: geometry behind it is not seen.
    float t_mirror = 0.0f;
    if (!ok(refl_plane_intersect_ray(&t_mirror, &mirror, reflected), "refl_plane_intersect_ray")) return 1;
    std::printf("primary ray:   origin (%.4f, %.4f, %.4f) dir (%.4f, %.4f, %.4f)\n", p(primary.origin.x),
                p(primary.origin.y), p(primary.origin.z), p(primary.dir.x), p(primary.dir.y), p(primary.dir.z));
    std::printf("reflected ray: origin (%.4f, %.4f, %.4f) dir (%.4f, %.4f, %.4f), trace from t = %.4f\n",
                p(reflected.origin.x), p(reflected.origin.y), p(reflected.origin.z), p(reflected.dir.x),
                p(reflected.dir.y), p(reflected.dir.z), p(t_mirror));

    // Errors are values, not crashes: a degenerate triangle is refused and
    // the output is left alone.
    refl_plane unused;
    const refl_status s = refl_plane_from_triangle(&unused, refl_vec3{0, 0, 0}, refl_vec3{1, 1, 1},
                                                   refl_vec3{2, 2, 2});
    std::printf("collinear triangle: %s\n", refl_status_string(s));
    return s == REFL_STATUS_DEGENERATE_GEOMETRY ? 0 : 1;
}
