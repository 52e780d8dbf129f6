//! Fuzzed image arguments of the pass targets (`temporal`, `bounce`,
//! `extrapolate`, `upsample`): a buffer with its descriptor's size and
//! stride, mostly of the expected size, sometimes another size, stride,
//! short, NULL or misaligned; per-pixel pseudo-random words and hostile
//! floats.

use crate::*;

/// A pseudo-random word of pixel `(x, y)` and `seed`.
pub fn hash(x: u32, y: u32, seed: u32) -> u32 {
    let mut h = x.wrapping_mul(0x9E37_79B1) ^ y.wrapping_mul(0x85EB_CA77) ^ seed.wrapping_mul(0xC2B2_AE3D);
    h ^= h >> 15;
    h = h.wrapping_mul(0x2C1B_3C6D);
    h ^ (h >> 13)
}

/// A hostile float for a color channel.
pub fn hostile(k: u32) -> f32 {
    [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, f32::MAX, -f32::MAX, 1e30, -1e-45, 3e38][(k % 8) as usize]
}

/// An image argument: its buffer and the descriptor's size and stride.
pub struct Img<T: Copy> {
    /// The texels.
    pub buf: Buf<T>,
    /// Descriptor width.
    pub w: u32,
    /// Descriptor height.
    pub h: u32,
    /// Descriptor stride.
    pub stride: u32,
}

impl<T: Copy> Img<T> {
    /// Fuzzed: mostly `w x h` with stride `w`, sometimes another size, a
    /// larger or smaller stride, a short, NULL or misaligned buffer.
    pub fn new(b: &mut Bytes, w: u32, h: u32, f: impl FnMut(u32, u32) -> T, pad: T) -> Self {
        let (iw, ih) = if b.chance(8) { (b.side(MAX_SIDE), b.side(MAX_SIDE)) } else { (w, h) };
        let stride = if b.chance(24) { b.stride(iw) } else { iw };
        let buf = image_buf(b, iw, ih, stride, f, pad);
        Self { buf, w: iw, h: ih, stride }
    }

    /// Sentinel bytes (an output), sized as [`Img::new`].
    pub fn output(b: &mut Bytes, w: u32, h: u32) -> Self {
        let (iw, ih) = if b.chance(8) { (b.side(MAX_SIDE), b.side(MAX_SIDE)) } else { (w, h) };
        let stride = if b.chance(24) { b.stride(iw) } else { iw };
        let need = required_len(iw, ih, stride).unwrap_or(16).min(1 << 16);
        let len = b.len_for(need);
        Self { buf: Buf::sentinel(len, b.ptr_kind()), w: iw, h: ih, stride }
    }

    /// An absent optional image (NULL data) of a fuzzed descriptor size.
    pub fn absent(b: &mut Bytes) -> Self {
        Self { buf: Buf::sentinel(0, PtrKind::Null), w: b.side(MAX_SIDE), h: b.side(MAX_SIDE), stride: 0 }
    }

    /// Whether refl must accept it as an image of `w x h`.
    pub fn valid(&self, w: u32, h: u32) -> bool {
        self.buf.usable() && self.w == w && self.h == h && required_len(self.w, self.h, self.stride).is_some_and(|n| self.buf.len() >= n)
    }

    /// Texel `(x, y)` (inside the descriptor and buffer).
    pub fn at(&self, x: u32, y: u32) -> T {
        self.buf.get(y as usize * self.stride as usize + x as usize)
    }

    /// Whether every texel outside the rows `rows` of a `w`-wide image
    /// (padding and texels past the image included) is still the
    /// sentinel.
    pub fn untouched_outside(&self, w: u32, rows: refl_row_range) -> bool {
        let s = self.stride.max(1) as usize;
        (0..self.buf.len()).all(|i| {
            let (x, y) = ((i % s) as u32, (i / s) as u32);
            (x < w && y >= rows.begin && y < rows.end) || self.buf.is_sentinel(i)
        })
    }
}

pub fn vec3_img(i: &Img<refl_vec3>) -> refl_image_vec3 {
    refl_image_vec3 { data: i.buf.cptr(), len: i.buf.len(), width: i.w, height: i.h, stride: i.stride }
}

pub fn vec3_mut(i: &mut Img<refl_vec3>) -> refl_image_vec3_mut {
    refl_image_vec3_mut { data: i.buf.ptr(), len: i.buf.len(), width: i.w, height: i.h, stride: i.stride }
}

pub fn u8_img(i: &Img<u8>) -> refl_image_u8 {
    refl_image_u8 { data: i.buf.cptr(), len: i.buf.len(), width: i.w, height: i.h, stride: i.stride }
}

pub fn u8_mut(i: &mut Img<u8>) -> refl_image_u8_mut {
    refl_image_u8_mut { data: i.buf.ptr(), len: i.buf.len(), width: i.w, height: i.h, stride: i.stride }
}

pub fn ssr_texel_img(i: &Img<refl_ssr_texel>) -> refl_image_ssr_texel {
    refl_image_ssr_texel { data: i.buf.cptr(), len: i.buf.len(), width: i.w, height: i.h, stride: i.stride }
}

/// The bits of a mirror-pass texel, for exact comparisons.
pub fn ssr_bits(t: &refl_ssr_texel) -> [u32; 5] {
    [t.status, t.pixel.x.to_bits(), t.pixel.y.to_bits(), t.t.to_bits(), t.confidence.to_bits()]
}

/// The mirror pass (`options`) over the whole G-buffer `g` of `w x h`
/// into valid outputs: status, texels, colors (with a G-buffer color).
pub fn mirror_run(g: &refl_gbuffer, o: &refl_ssr_options, w: u32, h: u32, with_color: bool) -> (refl_status, Vec<refl_ssr_texel>, Vec<refl_vec3>) {
    let n = w as usize * h as usize;
    let mut t = Buf::<refl_ssr_texel>::sentinel(n, PtrKind::Valid);
    let mut c = Buf::<refl_vec3>::sentinel(if with_color { n } else { 0 }, if with_color { PtrKind::Valid } else { PtrKind::Null });
    let cm = refl_image_vec3_mut { data: c.ptr(), len: c.len(), width: w, height: h, stride: w };
    let mut st = refl_ssr_stats::default();
    // SAFETY: valid outputs of the stated lengths; stepping needs no scratch.
    let s = unsafe {
        refl_ssr_trace_rows(&mut st, t.ptr(), n, cm, core::ptr::null_mut(), 0, g, o, core::ptr::null(), 0, refl_row_range { begin: 0, end: h })
    };
    no_panic(s, "refl_ssr_trace_rows");
    (s, t.to_vec(), c.to_vec())
}
