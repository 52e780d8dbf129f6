//! The test frame of the C G-buffer passes (`tests/ssr.rs`,
//! `tests/glossy.rs`, `tests/planar.rs`, `tests/layered_pass.rs`,
//! `tests/cluster_pass.rs`, `tests/summary.rs`, `tests/temporal.rs`;
//! included with `#[path]`):
//! the counting global allocator of `common/counting.rs` (zero-allocation
//! checks), a floor and a unit sphere rendered exactly into a G-buffer, and
//! its C and Rust descriptors.
// Each including test uses a different subset of the frame.
#![allow(dead_code)]

use refl::*;
use refl_core::glam::{Vec2, Vec3};
use refl_core::{Camera, DepthConvention, DepthImage, GBuffer, ImageView, NormalSpace};

#[path = "counting.rs"]
mod counting;
pub use counting::counted;

#[global_allocator]
static GLOBAL: counting::Counting = counting::Counting;

pub const W: u32 = 96;
pub const H: u32 = 64;

pub fn camera() -> Camera {
    Camera::try_look_at(
        Vec3::new(0.3, 2.0, 5.5),
        Vec3::new(0.0, 0.6, 0.0),
        Vec3::Y,
        1.0,
        0.1,
        50.0,
        W,
        H,
    )
    .unwrap()
}

/// A second frame's camera: [`camera`] moved a little to the right and
/// down, looking at the same point (`tests/temporal.rs`,
/// `tests/bounce.rs`).
pub fn moved_camera() -> Camera {
    Camera::try_look_at(
        Vec3::new(0.6, 1.85, 5.3),
        Vec3::new(0.05, 0.6, 0.0),
        Vec3::Y,
        1.0,
        0.1,
        50.0,
        W,
        H,
    )
    .unwrap()
}

pub struct Frame {
    pub cam: Camera,
    pub conv: DepthConvention,
    pub depth: Vec<f32>,
    pub back: Vec<f32>,
    pub normals: Vec<[f32; 3]>,
    pub color: Vec<[f32; 3]>,
    /// 0 the floor, 1 the sphere, `u32::MAX` nothing.
    pub ids: Vec<u32>,
}

/// A floor `y = 0` and a unit sphere at `(0, 1, 0)`, rendered exactly.
pub fn render(conv: DepthConvention) -> Frame {
    render_with(camera(), conv)
}

/// [`render`] through the camera `cam` (of `W x H` pixels).
pub fn render_with(cam: Camera, conv: DepthConvention) -> Frame {
    assert_eq!((cam.width(), cam.height()), (W, H));
    let n = (W * H) as usize;
    let far = cam.encode_depth(cam.far(), conv);
    let mut f = Frame {
        cam,
        conv,
        depth: vec![far; n],
        back: vec![far; n],
        normals: vec![[0.0; 3]; n],
        color: vec![[0.0; 3]; n],
        ids: vec![u32::MAX; n],
    };
    let eye = cam.eye().as_dvec3();
    let fwd = -cam.inverse_view().z_axis.truncate().as_dvec3();
    for y in 0..H {
        for x in 0..W {
            let i = (y * W + x) as usize;
            let d = cam
                .primary_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5))
                .dir
                .as_dvec3()
                .normalize();
            let c = refl_core::glam::DVec3::new(0.0, 1.0, 0.0);
            let oc = eye - c;
            let b = oc.dot(d);
            let disc = b * b - (oc.dot(oc) - 1.0);
            let mut best: Option<(f64, f64, refl_core::glam::DVec3, u32)> = None;
            if disc > 0.0 {
                let s = disc.sqrt();
                let t = -b - s;
                best = Some((t, -b + s, (eye + d * t - c).normalize(), 1));
            }
            if d.y < 0.0 {
                let t = -eye.y / d.y;
                if best.is_none_or(|(bt, ..)| t < bt) {
                    best = Some((t, f64::INFINITY, refl_core::glam::DVec3::Y, 0));
                }
            }
            if let Some((t, te, nn, id)) = best {
                let z = (t * d.dot(fwd)) as f32;
                let zb = ((te * d.dot(fwd)) as f32).min(cam.far());
                f.depth[i] = cam.encode_depth(z, conv);
                f.back[i] = cam.encode_depth(zb, conv);
                f.normals[i] = nn.as_vec3().to_array();
                f.ids[i] = id;
                f.color[i] = [id as f32, x as f32 / W as f32, y as f32 / H as f32];
            }
        }
    }
    f
}

pub fn img_f32(d: &[f32]) -> refl_image_f32 {
    refl_image_f32 {
        data: d.as_ptr(),
        len: d.len(),
        width: W,
        height: H,
        stride: W,
    }
}

pub fn img_vec3(d: &[[f32; 3]]) -> refl_image_vec3 {
    refl_image_vec3 {
        data: d.as_ptr().cast(),
        len: d.len(),
        width: W,
        height: H,
        stride: W,
    }
}

pub fn none_f32() -> refl_image_f32 {
    refl_image_f32 {
        data: core::ptr::null(),
        len: 0,
        width: 0,
        height: 0,
        stride: 0,
    }
}

pub fn none_vec3() -> refl_image_vec3 {
    refl_image_vec3 {
        data: core::ptr::null(),
        len: 0,
        width: 0,
        height: 0,
        stride: 0,
    }
}

pub fn none_u32() -> refl_image_u32 {
    refl_image_u32 {
        data: core::ptr::null(),
        len: 0,
        width: 0,
        height: 0,
        stride: 0,
    }
}

pub fn conv_c(c: DepthConvention) -> u32 {
    match c {
        DepthConvention::Linear => 0,
        DepthConvention::ZeroToOne => 1,
        DepthConvention::ReversedZ => 2,
    }
}

impl Frame {
    pub fn gbuffer_c(&self, back: bool) -> refl_gbuffer {
        refl_gbuffer {
            depth: refl_depth_image {
                depth: img_f32(&self.depth),
                camera: (&self.cam).into(),
                convention: conv_c(self.conv),
            },
            normals: img_vec3(&self.normals),
            normal_space: refl_normal_space::World as u32,
            mask: refl_image_u8 {
                data: core::ptr::null(),
                len: 0,
                width: 0,
                height: 0,
                stride: 0,
            },
            roughness: none_f32(),
            color: img_vec3(&self.color),
            back_depth: if back {
                img_f32(&self.back)
            } else {
                none_f32()
            },
        }
    }

    pub fn gbuffer(&self, back: bool) -> GBuffer<'_> {
        let d = DepthImage::try_new(
            ImageView::try_new(&self.depth, W, H, W).unwrap(),
            self.cam,
            self.conv,
        )
        .unwrap();
        let g = GBuffer::try_new(
            d,
            ImageView::try_new(&self.normals, W, H, W).unwrap(),
            NormalSpace::World,
        )
        .unwrap()
        .try_with_color(ImageView::try_new(&self.color, W, H, W).unwrap())
        .unwrap();
        if back {
            g.try_with_back_depth(ImageView::try_new(&self.back, W, H, W).unwrap())
                .unwrap()
        } else {
            g
        }
    }
}

pub fn color_mut(c: &mut [[f32; 3]]) -> refl_image_vec3_mut {
    refl_image_vec3_mut {
        data: c.as_mut_ptr().cast(),
        len: c.len(),
        width: W,
        height: H,
        stride: W,
    }
}

/// Descriptors shared by the band threads (each writes only its rows).
pub struct Shared<T>(pub T);

impl<T> Shared<T> {
    /// The value (a method, so that a closure captures the whole
    /// `Shared`, not its field).
    pub fn get(&self) -> &T {
        &self.0
    }
}
// SAFETY: the threads read the G-buffer and write disjoint rows.
unsafe impl<T> Sync for Shared<T> {}

/// An absent color output.
pub fn no_color() -> refl_image_vec3_mut {
    refl_image_vec3_mut {
        data: core::ptr::null_mut(),
        len: 0,
        width: 0,
        height: 0,
        stride: 0,
    }
}

/// Runs a failing `*_trace_rows` call through `call(stats, texels, color,
/// host, host_len)` with every output filled with sentinels (`texel`,
/// `stats`, colors of 5, host rays with `x = 77`; the color output only
/// `with_color`), and checks its status `want`, that it allocated nothing
/// and that no output changed.
pub fn refused_outputs<
    T: Copy + PartialEq + std::fmt::Debug,
    S: Copy + PartialEq + std::fmt::Debug,
>(
    want: refl_status,
    texel: T,
    stats: S,
    with_color: bool,
    call: impl FnOnce(&mut S, *mut T, refl_image_vec3_mut, *mut refl_host_ray, usize) -> refl_status,
) {
    let n = (W * H) as usize;
    let mut texels = vec![texel; n];
    let mut color = vec![[5.0f32; 3]; n];
    let mut host = vec![
        refl_host_ray {
            x: 77,
            ..Default::default()
        };
        8
    ];
    let mut st = stats;
    let cm = if with_color {
        color_mut(&mut color)
    } else {
        no_color()
    };
    let (s, allocs) = counted(|| {
        call(
            &mut st,
            texels.as_mut_ptr(),
            cm,
            host.as_mut_ptr(),
            host.len(),
        )
    });
    assert_eq!(s, want);
    assert_eq!(allocs, 0, "allocations on the error path");
    assert!(texels.iter().all(|t| *t == texel));
    assert!(color.iter().all(|c| *c == [5.0; 3]));
    assert!(host.iter().all(|h| h.x == 77));
    assert_eq!(st, stats);
}

/// A band call of a `*_trace_rows` export: `(stats, texels, texels_len,
/// color, host, host_len, rows)`, the rest of its arguments captured.
pub type BandCall<'a, T, S> = dyn Fn(
        &mut S,
        *mut T,
        usize,
        refl_image_vec3_mut,
        *mut refl_host_ray,
        usize,
        refl_row_range,
    ) -> refl_status
    + Sync
    + 'a;

/// Runs `call` over `bands` row bands (`refl_image_row_band`), one thread each,
/// all writing into `texels` and `color` (the whole image); returns each
/// band's written host rays and stats, in band order.
pub fn bands_from_threads<T: Default + Copy, S: Default + Send + HostRaysWritten>(
    texels: &mut [T],
    color: &mut [[f32; 3]],
    bands: u32,
    call: &BandCall<'_, T, S>,
) -> Vec<(Vec<refl_host_ray>, S)> {
    let n = (W * H) as usize;
    assert_eq!((texels.len(), color.len()), (n, n));
    let tp = texels.as_mut_ptr() as usize;
    let shared = Shared(color_mut(color));
    std::thread::scope(|s| {
        let hs: Vec<_> = (0..bands)
            .map(|b| {
                let shared = &shared;
                s.spawn(move || {
                    let c = shared.0;
                    let mut rows = refl_row_range::default();
                    // SAFETY: valid pointer.
                    assert_eq!(
                        unsafe { refl_image_row_band(&mut rows, H, b, bands) },
                        refl_status::Ok
                    );
                    let mut host = vec![refl_host_ray::default(); n];
                    let mut st = S::default();
                    // Each thread writes only its own rows of the texels
                    // and colors.
                    let r = call(&mut st, tp as *mut T, n, c, host.as_mut_ptr(), n, rows);
                    assert_eq!(r, refl_status::Ok);
                    host.truncate(st.host_rays_written() as usize);
                    (host, st)
                })
            })
            .collect();
        hs.into_iter().map(|h| h.join().unwrap()).collect()
    })
}

/// The stats of a `*_trace_rows` call: how many host rays it wrote.
pub trait HostRaysWritten {
    /// `host_rays_written`.
    fn host_rays_written(&self) -> u32;
}

impl HostRaysWritten for refl_ssr_stats {
    fn host_rays_written(&self) -> u32 {
        self.host_rays_written
    }
}

impl HostRaysWritten for refl_glossy_stats {
    fn host_rays_written(&self) -> u32 {
        self.host_rays_written
    }
}
