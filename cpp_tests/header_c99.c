/* header_c99: refl.h compiles as strict C99 (-std=c99 -pedantic -Werror)
 * and librefl links and runs from C. */
#include "refl.h"

#include <stdio.h>

int main(void) {
    refl_camera cam;
    refl_ray ray;
    refl_vec3 eye = {0.0f, 1.0f, 5.0f}, target = {0.0f, 0.0f, 0.0f}, up = {0.0f, 1.0f, 0.0f};
    refl_vec2 center = {32.0f, 24.0f};
    refl_status s;
    int failures = 0;

    if (refl_version_number() !=
        (((uint32_t)REFL_VERSION_MAJOR << 16) | ((uint32_t)REFL_VERSION_MINOR << 8) | REFL_VERSION_PATCH)) {
        fprintf(stderr, "header/library version mismatch: %s\n", refl_version());
        ++failures;
    }
    s = refl_camera_look_at(&cam, eye, target, up, 1.0f, 0.1f, 100.0f, 64, 48);
    if (s != REFL_STATUS_OK) {
        fprintf(stderr, "refl_camera_look_at: %s\n", refl_status_string(s));
        ++failures;
    }
    s = refl_camera_primary_ray(&ray, &cam, center);
    if (s != REFL_STATUS_OK || ray.dir.z > -0.9f) {
        fprintf(stderr, "refl_camera_primary_ray: %s\n", refl_status_string(s));
        ++failures;
    }
    s = refl_camera_primary_ray(NULL, &cam, center);
    if (s != REFL_STATUS_NULL_POINTER) {
        fprintf(stderr, "NULL output not reported: %s\n", refl_status_string(s));
        ++failures;
    }
    if (refl_status_string(12345u) == NULL) ++failures;
    printf("header_c99: refl %s, %s\n", refl_version(), failures ? "FAILED" : "OK");
    return failures ? 1 : 0;
}
