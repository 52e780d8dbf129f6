//! Links every public refl-core family into a `#![no_std]` staticlib.
#![no_std]

use refl_core::glam::{Vec2, Vec3};
use refl_core::{try_mirrored_camera, Camera, DepthConvention, Plane};

/// Exercises camera, depth conventions, image views and the mirror matrix so
/// that the linker must resolve them (and their libm calls) without std.
#[no_mangle]
pub extern "C" fn refl_no_std_check(buf: *mut f32, len: usize) -> f32 {
    let Ok(cam) = Camera::try_look_at(Vec3::new(0.0, 1.0, 3.0), Vec3::ZERO, Vec3::Y, 1.0, 0.1, f32::INFINITY, 4, 4) else {
        return -1.0;
    };
    let Ok(plane) = Plane::try_from_triangle(Vec3::ZERO, Vec3::X, Vec3::Z) else {
        return -2.0;
    };
    let Ok(m) = try_mirrored_camera(&cam, &plane) else {
        return -3.0;
    };
    let r = m.primary_ray(Vec2::new(2.0, 2.0));
    let d = cam.encode_depth(r.dir.length() + 1.0, DepthConvention::ReversedZ);
    if buf.is_null() {
        return d;
    }
    // SAFETY: the caller passes a buffer of `len` floats.
    #[allow(unsafe_code)]
    let data = unsafe { core::slice::from_raw_parts_mut(buf, len) };
    if let Ok(mut img) = refl_core::ImageViewMut::try_new(data, 2, 2, 2) {
        img.fill(d);
    }
    d
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    loop {}
}
