// header_cxx17: refl.h compiles as strict C++17 (-pedantic -Werror), its
// enums have uint32_t size, and its structs have the layout librefl expects.
#include "refl.h"

#include <cstddef>
#include <cstdio>
#include <type_traits>

static_assert(sizeof(refl_status) == 4, "refl_status is a uint32_t on the wire");
static_assert(sizeof(refl_depth_convention) == 4, "refl_depth_convention is a uint32_t");
static_assert(std::is_same<std::underlying_type<refl_status>::type, uint32_t>::value, "");
static_assert(REFL_STATUS_OK == 0, "");
static_assert(REFL_DEPTH_CONVENTION_LINEAR == 0 && REFL_DEPTH_CONVENTION_ZERO_TO_ONE == 1 &&
                  REFL_DEPTH_CONVENTION_REVERSED_Z == 2, "");
static_assert(sizeof(refl_vec2) == 8 && sizeof(refl_vec3) == 12 && sizeof(refl_vec4) == 16, "");
static_assert(sizeof(refl_mat4) == 64 && sizeof(refl_camera) == 84, "");
static_assert(offsetof(refl_camera, fov_y) == 64 && offsetof(refl_camera, height) == 80, "");
static_assert(sizeof(refl_ray) == 24 && sizeof(refl_plane) == 16 && sizeof(refl_rgba8) == 4, "");
static_assert(offsetof(refl_image_f32, len) == sizeof(void*), "");
static_assert(std::is_trivially_copyable<refl_camera>::value && std::is_standard_layout<refl_camera>::value, "");

int main() {
    const refl_status s = refl_image_required_len(nullptr, 1, 1, 1);
    std::printf("header_cxx17: %s\n", refl_status_string(s));
    return s == REFL_STATUS_NULL_POINTER ? 0 : 1;
}
