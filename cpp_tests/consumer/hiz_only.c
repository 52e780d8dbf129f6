/* hiz_only.c: a C99 host that uses only the Hi-Z family, built against a
 * refl installed with `scripts/install.sh --features hiz` (scripts/
 * install_test.sh). It traces a primary ray into the depth image of a wall
 * at linear depth 10 and checks the hit texel and distance.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "refl.h"

#if !defined(REFL_FEATURE_HIZ)
#error "refl_config.h should define REFL_FEATURE_HIZ in a hiz build"
#endif
#if defined(REFL_FEATURE_CONE) || defined(REFL_FEATURE_LAYERED) || defined(REFL_FEATURE_TCRR)
#error "a hiz build should not hold the cone, layered or tcrr families"
#endif

#define W 64
#define H 48

static int check(refl_status s, const char* what) {
    if (s != REFL_STATUS_OK) {
        char msg[256];
        refl_last_error_message(msg, sizeof msg);
        fprintf(stderr, "%s: %s (%s)\n", what, refl_status_string(s), msg);
        exit(1);
    }
    return 1;
}

int main(void) {
    static float depth[W * H];
    struct refl_camera cam;
    struct refl_vec3 eye = {0.0f, 0.0f, 0.0f}, target = {0.0f, 0.0f, -1.0f}, up = {0.0f, 1.0f, 0.0f};
    check(refl_camera_look_at(&cam, eye, target, up, 1.0471976f, 0.1f, 100.0f, W, H), "camera");
    for (int i = 0; i < W * H; ++i) depth[i] = 10.0f; /* a wall at linear depth 10 */

    struct refl_depth_image img = {{depth, W * H, W, H, W}, cam, REFL_DEPTH_CONVENTION_LINEAR};
    size_t len = 0;
    uint32_t levels = 0;
    check(refl_hiz_len(&len, &levels, W, H), "refl_hiz_len");
    struct refl_vec2* pyramid = malloc(len * sizeof *pyramid);
    check(refl_hiz_build(pyramid, len, &img), "refl_hiz_build");

    struct refl_hiz hiz = {pyramid, len, cam, REFL_DEPTH_CONVENTION_LINEAR};
    struct refl_trace_thickness thick = {0};
    thick.constant = 0.5f;
    struct refl_ray ray;
    struct refl_vec2 px = {40.5f, 20.5f};
    check(refl_camera_primary_ray(&ray, &cam, px), "primary ray");
    struct refl_hiz_options opt = refl_hiz_options_default();
    struct refl_trace_result r;
    check(refl_hiz_trace_ray(&r, &hiz, &thick, ray, 50.0f, &opt), "refl_hiz_trace_ray");

    /* The ray reaches z = -10 at t = (-10 - origin.z) / dir.z. */
    float t = (-10.0f - ray.origin.z) / ray.dir.z;
    if (r.miss != REFL_TRACE_MISS_NONE || (int)r.pixel.x != 40 || (int)r.pixel.y != 20 ||
        fabsf(r.t - t) > 0.05f) {
        fprintf(stderr, "expected a hit at texel (40, 20), t = %g; got miss %u at (%g, %g), t = %g\n",
                t, r.miss, r.pixel.x, r.pixel.y, r.t);
        return 1;
    }
    printf("hiz-only refl %s: hit texel (40, 20) at t = %.3f (expected %.3f)\n",
           refl_version(), r.t, t);
    free(pyramid);
    return 0;
}
