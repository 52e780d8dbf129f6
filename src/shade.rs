//! Shading: direct lighting of a surface point, the procedural environment
//! map, and the ray-traced reference reflection.
//!
//! # The one-bounce rule
//!
//! Every reflection method (the reference included) computes the radiance
//! arriving along a reflected ray the same way: the first surface hit is
//! shaded with its **direct** term only ([`Shader::direct`]: ambient plus
//! Lambertian lights, with the material's textured albedo), whatever that
//! surface's own specular level. A reflector seen in another reflector thus
//! shows its albedo, not a second reflection. A reflected ray that hits
//! nothing returns [`env_map`] in its direction. Methods therefore differ only
//! in *which* point they find along the reflected rays, which is what the
//! error metrics compare.
//!
//! # Glossy reference
//!
//! For roughness `r > 0` the reflection is the average of the incoming
//! radiance over the normalized Phong lobe of exponent
//! [`crate::scene::phong_exponent`]`(r)` around the mirror direction,
//! `(n + 1) / (2 pi) cos^n(theta)`. It is estimated by importance sampling that
//! lobe (inverse CDF `cos theta = xi^(1 / (n + 1))`, design.md erratum of seed
//! 004 Eq. 4.1; [`refl_core::lobe::sample_phong_lobe`]) with a Hammersley point
//! set under a per-pixel Cranley-Patterson rotation
//! ([`refl_core::lobe::hammersley`], [`refl_core::lobe::hash_rotation`];
//! deterministic, stratified): the lobe math of refl-core, not a copy. Samples below the geometric surface
//! are rejected and the estimate is the mean over the accepted ones, i.e. the
//! lobe is renormalized to the part above the surface; if every sample is
//! rejected the mirror direction is used. There is no Fresnel or cosine
//! factor: the reflection image is the lobe-filtered incoming radiance.

use crate::scene::{phong_exponent, Light, Scene};
use crate::tracer::{Hit, Tracer};
use glam::Vec3;
use refl_core::lobe::{hammersley, hash_rotation, pixel_hash, sample_phong_lobe};

/// Unit direction toward the sun, shared by the environment map's sun disc
/// and the built-in scenes' directional light (elevation about 53 degrees).
pub const SUN_DIRECTION: Vec3 = Vec3::new(0.477_670_4, 0.796_117_3, 0.371_521_4);

/// Cosine of the sun disc's angular radius (1.5 degrees).
const SUN_COS_RADIUS: f32 = 0.999_657_3;

/// The environment seen by rays that leave the scene, as a function of the
/// (not necessarily unit) direction only.
///
/// Above the horizon: a sky gradient from a pale horizon to a deep blue
/// zenith, bands of cloud-like stripes (so that misplaced reflections show)
/// and the sun (a 1.5 degree disc of value 1.6 plus a halo) at
/// [`SUN_DIRECTION`]. Below: a checkered ground plane one unit below the
/// viewer, fading to its mean color toward the horizon. Values are linear RGB
/// and may exceed 1 in the sun.
pub fn env_map(dir: Vec3) -> Vec3 {
    let d = dir.normalize_or_zero();
    if d.y >= 0.0 {
        let e = d.y;
        let horizon = Vec3::new(0.75, 0.84, 0.95);
        let zenith = Vec3::new(0.12, 0.3, 0.72);
        let mut c = horizon.lerp(zenith, e.sqrt());
        let azimuth = d.z.atan2(d.x);
        let band = (azimuth * 9.0 + (e * 14.0).sin() * 1.5).sin();
        c += Vec3::splat(smoothstep(0.55, 0.9, band) * (1.0 - e) * (1.0 - e) * 0.35);
        let sun_cos = d.dot(SUN_DIRECTION);
        c += Vec3::new(1.0, 0.9, 0.7) * 0.35 * sun_cos.max(0.0).powi(64);
        if sun_cos > SUN_COS_RADIUS {
            c = Vec3::new(1.6, 1.5, 1.3);
        }
        c
    } else {
        let t = -1.0 / d.y;
        let (gx, gz) = (d.x * t, d.z * t);
        let dark = Vec3::new(0.22, 0.2, 0.17);
        let light = Vec3::new(0.42, 0.38, 0.3);
        let cell = if (gx.floor() + gz.floor()).rem_euclid(2.0) >= 1.0 {
            dark
        } else {
            light
        };
        let fade = (-d.y * 8.0).min(1.0);
        ((dark + light) * 0.5).lerp(cell, fade)
    }
}

fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// A shaded surface point: where a ray hit a primitive, with everything
/// shading needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Surface {
    /// Hit point, world space (`origin + t dir` of the ray that found it).
    pub position: Vec3,
    /// Unit shading normal (interpolated vertex normals), on the side of the
    /// geometric normal below.
    pub shading_normal: Vec3,
    /// Unit geometric normal, facing the ray's origin.
    pub geo_normal: Vec3,
    /// Primitive id.
    pub prim: u32,
    /// Object id.
    pub object: u32,
    /// Material id.
    pub material: u32,
    /// Textured albedo at `position`.
    pub albedo: Vec3,
}

impl Surface {
    /// The surface where the ray `origin + t dir` hit `hit.prim` at `hit.t`
    /// with barycentrics `(hit.u, hit.v)`. Both normals are flipped to the
    /// side the ray came from.
    pub fn at_hit(scene: &Scene, origin: Vec3, dir: Vec3, hit: &Hit) -> Surface {
        let [a, b, c] = scene.tris[hit.prim as usize];
        let [na, nb, nc] = scene.normals[hit.prim as usize];
        let position = origin + dir * hit.t;
        let mut geo_normal = (b - a).cross(c - a).normalize_or_zero();
        let w = 1.0 - hit.u - hit.v;
        let mut shading_normal = (na * w + nb * hit.u + nc * hit.v).normalize_or(geo_normal);
        if geo_normal.dot(dir) > 0.0 {
            geo_normal = -geo_normal;
            shading_normal = -shading_normal;
        }
        let object = scene.tri_object[hit.prim as usize];
        let material = scene.objects[object as usize].material;
        Surface {
            position,
            shading_normal,
            geo_normal,
            prim: hit.prim,
            object,
            material,
            albedo: scene.materials[material as usize].albedo_at(position),
        }
    }
}

/// The mirror reflection direction for the unit direction `view` from the
/// surface toward the eye, with shading normal `ns` and geometric normal `ng`
/// (both facing the viewer): `refl_core::reflect(view, ns)`, and where that
/// points below the geometric surface (interpolated normals at silhouettes),
/// its mirror image about the geometric plane.
pub fn reflection_dir(view: Vec3, ns: Vec3, ng: Vec3) -> Vec3 {
    let r = refl_core::reflect(view, ns);
    let below = r.dot(ng);
    if below < 0.0 {
        (r - 2.0 * below * ng).normalize()
    } else {
        r
    }
}

/// Shading and reflection tracing over one scene and its tracer.
#[derive(Clone, Copy)]
pub struct Shader<'a> {
    /// The scene.
    pub scene: &'a Scene,
    /// Its tracer (for shadow and reflection rays).
    pub tracer: &'a Tracer,
    /// Trace hard shadow rays toward every light (deterministic). On by
    /// default.
    pub shadows: bool,
    /// Self-intersection tolerance of secondary rays
    /// ([`Scene::ray_epsilon`]): shadow rays start this far off the surface
    /// along the geometric normal; reflection rays start on the surface and
    /// ignore hits closer than this along the ray. (Offsetting reflection
    /// rays along the normal would shift every reflected ray sideways by
    /// epsilon, moving its hit point, which the exact planar method has no
    /// reason to reproduce.)
    pub epsilon: f32,
}

impl<'a> Shader<'a> {
    /// A shader with shadows on and the scene's ray epsilon.
    pub fn new(scene: &'a Scene, tracer: &'a Tracer) -> Self {
        Self {
            scene,
            tracer,
            shadows: true,
            epsilon: scene.ray_epsilon(),
        }
    }

    /// Direct lighting of `s`: `albedo * (ambient + sum_lights color * max(0,
    /// ns . l) * falloff * visibility)`. A light behind the geometric surface
    /// contributes nothing; visibility is a shadow ray from the point offset
    /// by [`Shader::epsilon`] along the geometric normal when
    /// [`Shader::shadows`] is on, else 1.
    pub fn direct(&self, s: &Surface) -> Vec3 {
        let mut irradiance = self.scene.ambient;
        let origin = s.position + s.geo_normal * self.epsilon;
        for light in &self.scene.lights {
            let (l, dist, color) = match *light {
                Light::Directional { direction, color } => (direction, f32::INFINITY, color),
                Light::Point {
                    position,
                    color,
                    range,
                } => {
                    let to = position - s.position;
                    let d = to.length();
                    if d == 0.0 {
                        continue;
                    }
                    (to / d, d, color / (1.0 + (d / range) * (d / range)))
                }
            };
            let cos = s.shading_normal.dot(l);
            if cos <= 0.0 || s.geo_normal.dot(l) <= 0.0 {
                continue;
            }
            if self.shadows && self.tracer.occluded(origin, l, 0.0, dist) {
                continue;
            }
            irradiance += color * cos;
        }
        s.albedo * irradiance
    }

    /// Radiance along a reflected ray that hit `hit`: the direct term of the
    /// hit surface (the one-bounce rule of the module docs).
    pub fn shade_reflection_hit(&self, origin: Vec3, dir: Vec3, hit: &Hit) -> Vec3 {
        self.direct(&Surface::at_hit(self.scene, origin, dir, hit))
    }

    /// Radiance along the ray `origin + t dir`, `t >= tmin`: the shaded
    /// first hit or the environment.
    pub fn trace_reflection(&self, origin: Vec3, dir: Vec3, tmin: f32) -> Vec3 {
        match self.tracer.trace(origin, dir, tmin, f32::INFINITY) {
            Some(hit) => self.shade_reflection_hit(origin, dir, &hit),
            None => env_map(dir),
        }
    }

    /// Radiance along the ray `origin + t dir`, `t >= tmin`, following
    /// perfect mirrors for up to `bounces` reflections (at least 1): a hit
    /// on a reflective surface of roughness 0, with bounces left, shows its
    /// direct term and its own mirror reflection composited as every
    /// renderer here composites (`direct (1 - specular) + reflection
    /// specular`, [`crate::render::composite`]); any other hit its direct
    /// term; a miss the environment. `bounces = 1` is
    /// [`Shader::trace_reflection`] exactly: the reference of two facing
    /// mirrors (seed 004 Sec. 4.6.4's multiple bounces) needs 2 or more.
    pub fn trace_reflection_bounces(
        &self,
        origin: Vec3,
        dir: Vec3,
        tmin: f32,
        bounces: u32,
    ) -> Vec3 {
        self.bounces(origin, dir, tmin, bounces, None)
    }

    /// [`Shader::trace_reflection_bounces`] with each further bounce
    /// weakened by `attenuation` as refl-core's bounce pass weakens it
    /// (seed 004 Sec. 4.6.4, Fig. 4.25: "the reflections lose intensity the
    /// further in reflection depth it gets"; the pass's `source = lit +
    /// attenuation (previous - lit)`, [`refl_core::bounce`], step 4): a
    /// perfect-mirror hit with bounces left shows `direct + attenuation
    /// (composite - direct)`, `composite = direct (1 - specular) +
    /// reflected specular` being what the unattenuated reference shows
    /// there. Attenuation 1 is [`Shader::trace_reflection_bounces`]
    /// exactly; 0 is the one-bounce rule.
    pub fn trace_reflection_bounces_attenuated(
        &self,
        origin: Vec3,
        dir: Vec3,
        tmin: f32,
        bounces: u32,
        attenuation: f32,
    ) -> Vec3 {
        let attenuation = (attenuation != 1.0).then_some(attenuation);
        self.bounces(origin, dir, tmin, bounces, attenuation)
    }

    /// The recursion of [`Shader::trace_reflection_bounces`] (attenuation
    /// `None`: the composite itself, bit for bit) and
    /// [`Shader::trace_reflection_bounces_attenuated`].
    fn bounces(
        &self,
        origin: Vec3,
        dir: Vec3,
        tmin: f32,
        bounces: u32,
        attenuation: Option<f32>,
    ) -> Vec3 {
        let Some(hit) = self.tracer.trace(origin, dir, tmin, f32::INFINITY) else {
            return env_map(dir);
        };
        let s = Surface::at_hit(self.scene, origin, dir, &hit);
        let direct = self.direct(&s);
        let m = &self.scene.materials[s.material as usize];
        if bounces <= 1 || !(m.specular > 0.0) || m.roughness != 0.0 {
            return direct;
        }
        let next = reflection_dir(-dir, s.shading_normal, s.geo_normal);
        let reflected = self.bounces(s.position, next, tmin, bounces - 1, attenuation);
        let composite = direct * (1.0 - m.specular) + reflected * m.specular;
        match attenuation {
            None => composite,
            Some(a) => direct + (composite - direct) * a,
        }
    }

    /// The ray-traced reference reflection at surface `s` seen along the
    /// unit direction `view` (surface toward the eye), for `roughness`:
    /// one mirror ray for roughness 0, otherwise the glossy estimate of the
    /// module docs with `samples` (at least 1) lobe samples rotated by
    /// `seed` (e.g. the pixel index). Rays start at the surface point with
    /// `tmin =` [`Shader::epsilon`].
    pub fn reference_reflection(
        &self,
        s: &Surface,
        view: Vec3,
        roughness: f32,
        samples: u32,
        seed: u32,
    ) -> Vec3 {
        let mirror = reflection_dir(view, s.shading_normal, s.geo_normal);
        let (origin, tmin) = (s.position, self.epsilon);
        if roughness <= 0.0 {
            return self.trace_reflection(origin, mirror, tmin);
        }
        let exponent = phong_exponent(roughness);
        let samples = samples.max(1);
        let rotation = hash_rotation(pixel_hash(seed));
        let mut sum = Vec3::ZERO;
        let mut accepted = 0u32;
        for i in 0..samples {
            let xi = (hammersley(i, samples) + rotation).fract();
            let dir = sample_phong_lobe(mirror, exponent, xi);
            if dir.dot(s.geo_normal) <= 0.0 {
                continue;
            }
            sum += self.trace_reflection(origin, dir, tmin);
            accepted += 1;
        }
        if accepted == 0 {
            self.trace_reflection(origin, mirror, tmin)
        } else {
            sum / accepted as f32
        }
    }
}
