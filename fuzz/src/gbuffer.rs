//! A fuzzed `refl_gbuffer` for the pass targets (`ssr`, `glossy`): depth
//! with its camera and convention ([`depth_image`]), normals in either
//! space, and optional mask, roughness, lit color and back-face depth, each
//! sometimes of the wrong size or stride, short, NULL or misaligned.

use crate::*;

/// The buffers behind a fuzzed G-buffer and its descriptor.
pub struct FuzzGBuffer {
    /// Depth, camera and convention.
    pub img: DepthImg,
    /// Normals and their descriptor's width, height, stride.
    pub normals: (Buf<refl_vec3>, u32, u32, u32),
    /// The `refl_normal_space` value passed (may be unknown).
    pub normal_space: u32,
    /// Mask (data NULL: absent).
    pub mask: (Buf<u8>, u32, u32, u32),
    /// Roughness (data NULL: absent): NaN, 0, 0.3, 0.5 or 0.9 per pixel.
    pub roughness: (Buf<f32>, u32, u32, u32),
    /// Lit color `(x, y, 1)` (data NULL: absent).
    pub color: (Buf<refl_vec3>, u32, u32, u32),
    /// Back-face depth (data NULL: absent).
    pub back: (Buf<f32>, u32, u32, u32),
    snaps: [Vec<u8>; 6],
}

/// An optional G-buffer image: absent (NULL data) with probability
/// `absent / 256`, sometimes of another size or stride.
fn optional<T: Copy>(
    b: &mut Bytes,
    w: u32,
    h: u32,
    absent: u8,
    f: impl FnMut(u32, u32) -> T,
    pad: T,
) -> (Buf<T>, u32, u32, u32) {
    let absent = b.chance(absent);
    let (iw, ih) = if b.chance(8) { (b.side(MAX_SIDE), b.side(MAX_SIDE)) } else { (w, h) };
    let stride = if b.chance(24) { b.stride(iw) } else { iw };
    let buf = if absent { Buf::sentinel(0, PtrKind::Null) } else { image_buf(b, iw, ih, stride, f, pad) };
    (buf, iw, ih, stride)
}

impl FuzzGBuffer {
    /// A G-buffer from the fuzz input; `absent` is the chance (of 256)
    /// that each optional image is left out (the glossy pass needs the
    /// color and the roughness: it passes a small one for those).
    pub fn new(b: &mut Bytes, absent: [u8; 4]) -> Self {
        let img = depth_image(b);
        let (w, h) = (img.width, img.height);
        let floor_n = b.u8();
        let normals = {
            let (iw, ih) = if b.chance(8) { (b.side(MAX_SIDE), b.side(MAX_SIDE)) } else { (w, h) };
            let stride = if b.chance(24) { b.stride(iw) } else { iw };
            let seed = b.u8();
            let buf = image_buf(
                b,
                iw,
                ih,
                stride,
                |x, y| match (x.wrapping_mul(7) ^ y.wrapping_mul(13) ^ u32::from(seed)) % 11 {
                    0 => v3(f32::NAN, 0.0, 1.0),
                    1 => v3(0.0, 0.0, 0.0),
                    2 => v3(0.3, 0.9, -0.2),
                    3 => v3(0.0, 0.0, 1.0),
                    4 => v3(1e30, 1e30, 0.0),
                    _ if floor_n < 200 => v3(0.0, 1.0, 0.0),
                    _ => v3(-0.6, 0.0, 0.8),
                },
                v3(7.0, 7.0, 7.0),
            );
            (buf, iw, ih, stride)
        };
        let normal_space = match b.u8() {
            0..=3 => b.pick(&[2, 0xFFFF_FFFF]),
            k => u32::from(k & 1),
        };
        let mseed = b.u8();
        let mask = optional(b, w, h, absent[0], |x, y| u8::from(x.wrapping_add(y).wrapping_add(u32::from(mseed)) % 5 != 0), 3u8);
        let rseed = b.u8();
        let roughness = optional(
            b,
            w,
            h,
            absent[1],
            |x, y| match x.wrapping_mul(3).wrapping_add(y).wrapping_add(u32::from(rseed)) % 9 {
                0 => f32::NAN,
                1 => 0.5,
                2 => 0.3,
                3 => 0.9,
                _ => 0.0,
            },
            0.25,
        );
        let color = optional(b, w, h, absent[2], |x, y| v3(x as f32, y as f32, 1.0), v3(-1.0, -1.0, -1.0));
        let push = b.f32_in(0.0, 0.05);
        let back = optional(
            b,
            w,
            h,
            absent[3],
            |x, y| {
                let inside = x < img.width
                    && y < img.height
                    && u64::from(y) * u64::from(img.stride) + u64::from(x) < img.buf.len() as u64
                    && img.buf.usable();
                if inside {
                    // Pushed toward the far value of any convention: the
                    // exact arithmetic does not matter, only that it is a
                    // plausible back image (and sometimes not).
                    let z = img.texel(x, y);
                    if img.conv == 1 { z - push } else { z + push }
                } else {
                    f32::NAN
                }
            },
            f32::NAN,
        );
        let snaps = [
            img.buf.snapshot(),
            normals.0.snapshot(),
            mask.0.snapshot(),
            roughness.0.snapshot(),
            color.0.snapshot(),
            back.0.snapshot(),
        ];
        Self { img, normals, normal_space, mask, roughness, color, back, snaps }
    }

    /// The C descriptor over the buffers.
    pub fn desc(&self) -> refl_gbuffer {
        let (n, m, r, c, k) = (&self.normals, &self.mask, &self.roughness, &self.color, &self.back);
        refl_gbuffer {
            depth: self.img.desc(),
            normals: refl_image_vec3 { data: n.0.cptr(), len: n.0.len(), width: n.1, height: n.2, stride: n.3 },
            normal_space: self.normal_space,
            mask: refl_image_u8 { data: m.0.cptr(), len: m.0.len(), width: m.1, height: m.2, stride: m.3 },
            roughness: img_f32(&r.0, r.1, r.2, r.3),
            color: refl_image_vec3 { data: c.0.cptr(), len: c.0.len(), width: c.1, height: c.2, stride: c.3 },
            back_depth: img_f32(&k.0, k.1, k.2, k.3),
        }
    }

    /// Whether the G-buffer has a lit color (a non-NULL pointer).
    pub fn has_color(&self) -> bool {
        !self.color.0.is_null()
    }

    /// Asserts that no input byte changed since [`FuzzGBuffer::new`].
    #[track_caller]
    pub fn assert_unchanged(&self, what: &str) {
        self.img.buf.assert_unchanged(&self.snaps[0], what);
        self.normals.0.assert_unchanged(&self.snaps[1], what);
        self.mask.0.assert_unchanged(&self.snaps[2], what);
        self.roughness.0.assert_unchanged(&self.snaps[3], what);
        self.color.0.assert_unchanged(&self.snaps[4], what);
        self.back.0.assert_unchanged(&self.snaps[5], what);
    }

    /// After the pass accepted the G-buffer: every present image has the
    /// camera's size and the normal space is known.
    #[track_caller]
    pub fn assert_accepted(&self, what: &str) {
        let (w, h) = (self.img.width, self.img.height);
        assert!(self.img.valid(), "{what} accepted an invalid depth image");
        assert!(self.normals.1 == w && self.normals.2 == h, "{what} accepted normals of another size");
        assert!(self.normal_space <= 1, "{what} accepted normal space {}", self.normal_space);
        for (name, present, iw, ih) in [
            ("mask", !self.mask.0.is_null(), self.mask.1, self.mask.2),
            ("roughness", !self.roughness.0.is_null(), self.roughness.1, self.roughness.2),
            ("color", self.has_color(), self.color.1, self.color.2),
            ("back depth", !self.back.0.is_null(), self.back.1, self.back.2),
        ] {
            assert!(!present || (iw == w && ih == h), "{what} accepted a {name} image of {iw}x{ih} for {w}x{h}");
        }
    }

    /// Whether pixel `(x, y)` is masked out (a present mask reading 0).
    pub fn masked(&self, x: u32, y: u32) -> bool {
        !self.mask.0.is_null() && self.mask.0.get((y * self.mask.3 + x) as usize) == 0
    }

    /// The roughness of pixel `(x, y)` (None without a roughness image).
    pub fn roughness_at(&self, x: u32, y: u32) -> Option<f32> {
        (!self.roughness.0.is_null()).then(|| self.roughness.0.get((y * self.roughness.3 + x) as usize))
    }

    /// The lit color of pixel `(x, y)` (a present color image).
    pub fn color_at(&self, x: u32, y: u32) -> refl_vec3 {
        self.color.0.get((y * self.color.3 + x) as usize)
    }

    /// The normal of pixel `(x, y)`.
    pub fn normal_at(&self, x: u32, y: u32) -> refl_vec3 {
        self.normals.0.get((y * self.normals.3 + x) as usize)
    }
}

/// The bits of a vector, for exact comparisons.
pub fn bits3(v: refl_vec3) -> [u32; 3] {
    [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()]
}

/// The bits of a host ray, field by field.
pub fn host_bits(r: &refl_host_ray) -> [u32; 11] {
    let (o, d) = (bits3(r.origin), bits3(r.dir));
    [r.x, r.y, o[0], o[1], o[2], d[0], d[1], d[2], r.t_min.to_bits(), r.t_max.to_bits(), r.status]
}

/// Whether two host rays are the same, bit for bit.
pub fn same_host(a: &refl_host_ray, b: &refl_host_ray) -> bool {
    host_bits(a) == host_bits(b)
}
