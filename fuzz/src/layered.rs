//! Layered depth maps as the targets `layered` and `layered_pass` build
//! them: the size query, an identity placement, the four buffers of a map
//! (each sometimes NULL, misaligned or short) and the grid's validity.

use crate::*;

/// `refl_layered_len` of `res` and `layers`, `None` when refused.
pub fn sizes(res: u32, layers: u32) -> Option<refl_layered_sizes> {
    let mut o = refl_layered_sizes::default();
    // SAFETY: pointer valid.
    (unsafe { refl_layered_len(&mut o, res, layers) } == refl_status::Ok).then_some(o)
}

/// The identity placement.
pub fn identity() -> refl_mat4 {
    let mut m = [0.0; 16];
    m[0] = 1.0;
    m[5] = 1.0;
    m[10] = 1.0;
    m[15] = 1.0;
    refl_mat4 { m }
}

/// The buffers of one map (fuzzed kinds and lengths) and its grid.
pub struct Map {
    pub grid: refl_layered_grid,
    pub depth: Buf<f32>,
    pub payload: Buf<u32>,
    pub counts: Buf<u32>,
    pub bounds: Buf<f32>,
}

impl Map {
    /// The mutable C descriptor over the buffers.
    pub fn desc_mut(&mut self) -> refl_layered_map_mut {
        refl_layered_map_mut {
            grid: self.grid,
            depth: self.depth.ptr(),
            depth_len: self.depth.len(),
            payload: self.payload.ptr(),
            payload_len: self.payload.len(),
            counts: self.counts.ptr(),
            counts_len: self.counts.len(),
            bounds: self.bounds.ptr(),
            bounds_len: self.bounds.len(),
        }
    }
    /// The C descriptor over the buffers.
    pub fn desc(&self) -> refl_layered_map {
        refl_layered_map {
            grid: self.grid,
            depth: self.depth.cptr(),
            depth_len: self.depth.len(),
            payload: self.payload.cptr(),
            payload_len: self.payload.len(),
            counts: self.counts.cptr(),
            counts_len: self.counts.len(),
            bounds: self.bounds.cptr(),
            bounds_len: self.bounds.len(),
        }
    }
    /// The four buffers' bytes.
    pub fn snap(&self) -> [Vec<u8>; 4] {
        [self.depth.snapshot(), self.payload.snapshot(), self.counts.snapshot(), self.bounds.snapshot()]
    }
    /// Whether the buffers still hold the bytes of [`Map::snap`].
    pub fn same(&self, s: &[Vec<u8>; 4]) -> bool {
        self.depth.bytes() == &s[0][..]
            && self.payload.bytes() == &s[1][..]
            && self.counts.bytes() == &s[2][..]
            && self.bounds.bytes() == &s[3][..]
    }
    /// Whether a buffer is NULL.
    pub fn any_null(&self) -> bool {
        self.depth.is_null() || self.payload.is_null() || self.counts.is_null() || self.bounds.is_null()
    }
    /// Whether a buffer is misaligned.
    pub fn any_misaligned(&self) -> bool {
        [self.depth.kind(), self.payload.kind(), self.counts.kind(), self.bounds.kind()].contains(&PtrKind::Misaligned)
    }
    /// Whether every buffer is valid and at least its size in `z`.
    pub fn usable(&self, z: &refl_layered_sizes) -> bool {
        self.depth.usable()
            && self.payload.usable()
            && self.counts.usable()
            && self.bounds.usable()
            && self.depth.len() >= z.depth_len
            && self.payload.len() >= z.payload_len
            && self.counts.len() >= z.counts_len
            && self.bounds.len() >= z.bounds_len
    }
}

/// Whether `g` is a grid refl must accept (finite, non-empty box, sizes
/// at least 1, an affine placement).
pub fn grid_ok(g: &refl_layered_grid) -> bool {
    let f = finite3(g.min) && finite3(g.max) && finite_mat(&g.world_from_local);
    let m = &g.world_from_local.m;
    f && g.min.x < g.max.x
        && g.min.y < g.max.y
        && g.min.z < g.max.z
        && g.face_res >= 1
        && g.layers >= 1
        && [m[3], m[7], m[11], m[15]] == [0.0, 0.0, 0.0, 1.0]
}
