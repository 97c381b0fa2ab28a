//! Plain-Rust reference of the visibility and direct-light passes: the same camera rays,
//! surface reconstruction, texture filtering, light sampling (bit-identical sample
//! points) and shading, with shadow and camera rays traced by obvhs on the CPU.

use crate::bvh::cpu_trace::{CpuHit, CpuTracer};
use crate::bvh::normal_matrix;
use crate::sampling::{cosine_hemisphere, hash_combine, hash_u32, orthonormal_basis, sobol_2d};
use crate::scene::{Light, Scene, Texture};
use crate::visibility::GpuCamera;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// A shaded point, as WGSL `Surface`.
#[derive(Clone, Copy, Debug)]
pub struct Surface {
    pub position: Vec3,
    pub geometric_normal: Vec3,
    pub shading_normal: Vec3,
    pub uv: Vec2,
    pub material: u32,
    pub front_face: bool,
}

/// Per-pixel result of the reference.
#[derive(Clone, Copy, Debug, Default)]
pub struct ReferencePixel {
    pub hit: Option<(u32, u32)>,
    pub beauty: Vec3,
    pub albedo: Vec3,
    pub direct: Vec3,
}

/// CPU reference renderer for direct light.
pub struct DirectReference<'a> {
    pub scene: &'a Scene,
    pub tracer: CpuTracer,
    pub light_samples: u32,
}

impl<'a> DirectReference<'a> {
    pub fn new(scene: &'a Scene, light_samples: u32) -> Self {
        Self {
            scene,
            tracer: CpuTracer::new(scene),
            light_samples: light_samples.max(1),
        }
    }

    /// Reconstructs the surface at a CPU hit.
    pub fn surface_at(&self, hit: &CpuHit, ray_dir: Vec3) -> Surface {
        let inst = &self.scene.instances[hit.instance as usize];
        let mesh = &self.scene.meshes[inst.mesh as usize];
        let idx = mesh.indices[hit.triangle as usize];
        let p = |k: usize| mesh.positions[idx[k] as usize];
        let (u, v) = (hit.u, hit.v);
        let w = 1.0 - u - v;
        let (e1, e2) = (p(1) - p(0), p(2) - p(0));
        let position = inst.transform.transform_point3(p(0) + u * e1 + v * e2);
        let nm = normal_matrix(inst.transform);
        let mut ng = (nm * e1.cross(e2)).normalize();
        let n = |k: usize| {
            mesh.normals
                .get(idx[k] as usize)
                .copied()
                .unwrap_or(Vec3::ZERO)
        };
        let mut ns = ng;
        if (0..3).all(|k| n(k).length_squared() > 0.0) {
            let n_obj = w * n(0) + u * n(1) + v * n(2);
            if n_obj.length_squared() > 1e-12 {
                ns = (nm * n_obj).normalize();
            }
        }
        let front_face = ng.dot(ray_dir) < 0.0;
        if !front_face {
            ng = -ng;
        }
        if ns.dot(ng) < 0.0 {
            ns = -ns;
        }
        let uv = |k: usize| mesh.uvs.get(idx[k] as usize).copied().unwrap_or_default();
        Surface {
            position,
            geometric_normal: ng,
            shading_normal: ns,
            uv: w * uv(0) + u * uv(1) + v * uv(2),
            material: mesh.material_ids[hit.triangle as usize],
            front_face,
        }
    }

    /// Emission seen by a secondary ray: zero for emitters sampled as lights (Ward's rule)
    /// and from behind, as WGSL `indirect_emission`.
    pub fn indirect_emission(&self, s: &Surface) -> Vec3 {
        let m = &self.scene.materials[s.material as usize];
        if m.sampled_light || !s.front_face {
            Vec3::ZERO
        } else {
            m.emission
        }
    }

    /// Textured albedo, as WGSL `surface_albedo`.
    pub fn albedo(&self, s: &Surface) -> Vec3 {
        let m = &self.scene.materials[s.material as usize];
        match m.albedo_texture {
            None => m.albedo,
            Some(t) => m.albedo * sample_texture(&self.scene.textures[t as usize], s.uv),
        }
    }

    fn visible(&self, s: &Surface, target: Vec3, to_infinity: bool) -> bool {
        let origin = offset_ray_origin(s.position, s.geometric_normal);
        if to_infinity {
            !self.tracer.occluded(origin, target, 0.0, f32::INFINITY)
        } else {
            !self
                .tracer
                .occluded(origin, target - origin, 0.0, 1.0 - 1e-4)
        }
    }

    /// Direct irradiance, as WGSL `direct_irradiance`.
    pub fn direct_irradiance(&self, s: &Surface, seed: u32) -> Vec3 {
        self.direct_irradiance_at(s, seed, 0)
    }

    /// The same with the light samples from index `first` of their sequences on, as WGSL
    /// `shadow_loop_start_at` (hemisphere planes: `plane_light_first`).
    pub fn direct_irradiance_at(&self, s: &Surface, seed: u32, first: u32) -> Vec3 {
        self.direct_light_at(s, seed, first, |_, _| {})
    }

    /// Direct irradiance as [`DirectReference::direct_irradiance_at`], calling `visible_sample`
    /// with each visible shadow sample's direction and share of the irradiance (`L cos dw`):
    /// what a glossy lobe weighs (WGSL `shadow_sample_direction`, `shadow_sample_irradiance`).
    pub fn direct_light_at(
        &self,
        s: &Surface,
        seed: u32,
        first: u32,
        visible_sample: impl FnMut(Vec3, Vec3),
    ) -> Vec3 {
        self.direct_light_from(s, seed, first, None, visible_sample)
    }

    /// Direct irradiance of a hemisphere-plane hit, as WGSL `shadow_loop_start_chosen`:
    /// from `choices` lights chosen by weight ([`choose_lights`]), or every light.
    pub fn plane_direct_irradiance_at(
        &self,
        s: &Surface,
        seed: u32,
        first: u32,
        choices: u32,
    ) -> Vec3 {
        self.plane_direct_irradiance_split(s, seed, first, choices)
            .0
    }

    /// [`DirectReference::plane_direct_irradiance_at`] and the environment's share of it
    /// (WGSL `ShadowLoop::e_env`).
    pub fn plane_direct_irradiance_split(
        &self,
        s: &Surface,
        seed: u32,
        first: u32,
        choices: u32,
    ) -> (Vec3, Vec3) {
        let factors = choose_lights(&self.scene.lights, s, seed, first, choices);
        self.direct_light_split(s, seed, first, factors.as_deref(), |_, _| {})
    }

    /// [`DirectReference::direct_light_at`] from every light (`factors` None) or from the
    /// lights with a non-zero factor, what each adds multiplied by it (as WGSL: `e_before +
    /// (e - e_before) factor`).
    fn direct_light_from(
        &self,
        s: &Surface,
        seed: u32,
        first: u32,
        factors: Option<&[f32]>,
        visible_sample: impl FnMut(Vec3, Vec3),
    ) -> Vec3 {
        self.direct_light_split(s, seed, first, factors, visible_sample)
            .0
    }

    /// [`DirectReference::direct_light_from`] and the environment's share of it.
    fn direct_light_split(
        &self,
        s: &Surface,
        seed: u32,
        first: u32,
        factors: Option<&[f32]>,
        mut visible_sample: impl FnMut(Vec3, Vec3),
    ) -> (Vec3, Vec3) {
        let (n, ng) = (s.shading_normal, s.geometric_normal);
        let count = self.light_samples;
        let mut e = Vec3::ZERO;
        for (li, light) in self.scene.lights.iter().enumerate() {
            let factor = factors.map(|f| f[li]);
            if factor == Some(0.0) {
                continue;
            }
            let e_before = e;
            match *light {
                Light::Point {
                    position,
                    intensity,
                }
                | Light::Spot {
                    position,
                    intensity,
                    ..
                } => {
                    let to_light = position - s.position;
                    let d2 = to_light.length_squared();
                    let l = to_light / d2.sqrt();
                    let cos_s = n.dot(l);
                    if cos_s <= 0.0 || ng.dot(l) <= 0.0 {
                        continue;
                    }
                    let mut intensity = intensity;
                    if let Light::Spot {
                        direction,
                        cos_inner,
                        cos_outer,
                        ..
                    } = *light
                    {
                        intensity *=
                            smoothstep(cos_outer, cos_inner, (-l).dot(direction.normalize()));
                    }
                    if intensity == Vec3::ZERO || !self.visible(s, position, false) {
                        continue;
                    }
                    visible_sample(l, intensity * (cos_s / d2));
                    e += intensity * cos_s / d2;
                }
                Light::Sun {
                    direction,
                    irradiance,
                } => {
                    let l = direction.normalize();
                    let cos_s = n.dot(l);
                    if cos_s <= 0.0 || ng.dot(l) <= 0.0 || !self.visible(s, l, true) {
                        continue;
                    }
                    visible_sample(l, irradiance * cos_s);
                    e += irradiance * cos_s;
                }
                Light::Rect {
                    corner,
                    edge_u,
                    edge_v,
                    radiance,
                } => {
                    let light_seed = hash_combine(seed, li as u32);
                    let mut sum = 0.0;
                    for k in 0..count {
                        let xi = sobol_2d(first + k, light_seed);
                        let rs = rect_light_sample(corner, edge_u, edge_v, s.position, xi);
                        let to_q = rs.point - s.position;
                        let d2 = to_q.length_squared();
                        let l = to_q / d2.sqrt();
                        let cos_s = n.dot(l);
                        if cos_s <= 0.0 || rs.weight <= 0.0 || ng.dot(l) <= 0.0 {
                            continue;
                        }
                        if self.visible(s, rs.point, false) {
                            visible_sample(l, radiance * (cos_s * rs.weight / count as f32));
                            sum += cos_s * rs.weight;
                        }
                    }
                    e += radiance * (sum / count as f32);
                }
            }
            if let Some(factor) = factor {
                // A chosen light: what it added, weighed (as WGSL `shadow_loop_next`).
                e = e_before + (e - e_before) * factor;
            }
        }
        let env = self.scene.environment;
        let mut e_env = Vec3::ZERO;
        if let Some(map) = &self.scene.environment_map {
            // As WGSL: directions drawn from the map, E = mean of V L cos / pdf.
            let env_seed = hash_combine(seed, 0xe17);
            let mut sum = Vec3::ZERO;
            for k in 0..count {
                let Some((dir, pdf)) = map.sample(sobol_2d(first + k, env_seed)) else {
                    continue;
                };
                let cos_s = n.dot(dir);
                if pdf.is_nan() || pdf <= 0.0 || cos_s <= 0.0 || ng.dot(dir) <= 0.0 {
                    continue;
                }
                if self.visible(s, dir, true) {
                    let c = map.radiance(dir) * (cos_s / pdf);
                    visible_sample(dir, c / count as f32);
                    sum += c;
                }
            }
            let add = sum / count as f32;
            e += add;
            e_env += add;
        } else if env != Vec3::ZERO {
            let frame = orthonormal_basis(n);
            let env_seed = hash_combine(seed, 0xe17);
            let unoccluded = (0..count)
                .filter(|&k| {
                    let dir = frame * cosine_hemisphere(sobol_2d(first + k, env_seed));
                    let seen = dir.dot(ng) > 0.0 && self.visible(s, dir, true);
                    if seen {
                        visible_sample(dir, env * (PI / count as f32));
                    }
                    seen
                })
                .count();
            let add = env * (PI * unoccluded as f32 / count as f32);
            e += add;
            e_env += add;
        }
        (e, e_env)
    }

    /// Renders one pixel.
    pub fn pixel(&self, camera: &GpuCamera, x: u32, y: u32) -> ReferencePixel {
        let dir = camera.ray_dir(x, y);
        let Some(hit) =
            self.tracer
                .closest_hit(camera.origin.into(), dir, camera.tmin, f32::INFINITY)
        else {
            return ReferencePixel {
                beauty: match &self.scene.environment_map {
                    Some(map) => map.radiance(dir),
                    None => self.scene.environment,
                },
                ..Default::default()
            };
        };
        let s = self.surface_at(&hit, dir);
        let albedo = self.albedo(&s);
        let pixel = y * camera.width + x;
        let m = &self.scene.materials[s.material as usize];
        // As direct_light.wgsl: the glossy lobe weighs the same visible shadow samples.
        let wo = -dir;
        let mut glossy = Vec3::ZERO;
        let e = self.direct_light_at(&s, hash_u32(pixel), 0, |wi, share| {
            if let Some(lobe) = &m.glossy {
                glossy += lobe.eval(s.shading_normal, wo, wi) * share;
            }
        });
        let direct = albedo / PI * e + glossy;
        let emission = if s.front_face { m.emission } else { Vec3::ZERO };
        ReferencePixel {
            hit: Some((hit.instance, hit.triangle)),
            beauty: emission + direct,
            albedo,
            direct,
        }
    }
}

/// A point on a rect light for a receiver and the solid angle one sample stands for
/// (WGSL `RectSample`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RectSample {
    pub point: Vec3,
    /// cos_l A / d^2 drawn by area, Omega drawn by solid angle; 0 behind the light.
    pub weight: f32,
}

/// Rect lights subtending less than this solid angle are drawn by area (WGSL
/// `RECT_AREA_SAMPLING_BELOW`).
pub const RECT_AREA_SAMPLING_BELOW: f32 = 1.0e-2;

/// Sample `xi` of the rect light `corner + u edge_u + v edge_v` seen from `origin`: drawn
/// uniformly in the solid angle a rectangle subtends (Urena, Fajardo and King 2013), by
/// area for parallelograms and small solid angles. Mirrors WGSL `rect_light_sample` (the
/// same operations in f32; points agree to a few ulps of the GPU's transcendentals).
pub fn rect_light_sample(
    corner: Vec3,
    edge_u: Vec3,
    edge_v: Vec3,
    origin: Vec3,
    xi: Vec2,
) -> RectSample {
    let (bl, cl) = (edge_u.length(), edge_v.length());
    let (ex, ey) = (edge_u / bl, edge_v / cl);
    let ez = ex.cross(ey).normalize();
    let rel = corner - origin;
    let z0 = rel.dot(ez);
    let area_point = corner + xi.x * edge_u + xi.y * edge_v;
    let mut out = RectSample {
        point: area_point,
        weight: 0.0,
    };
    if z0 >= 0.0 {
        return out;
    }
    let (x0, y0) = (rel.dot(ex), rel.dot(ey));
    let (x1, y1) = (x0 + bl, y0 + cl);
    let mut omega = 0.0;
    let (mut n0, mut n2, mut au0) = (Vec3::ZERO, Vec3::ZERO, 0.0);
    let square = ex.dot(ey).abs() < 1.0e-4;
    if square {
        let v00 = Vec3::new(x0, y0, z0);
        let v01 = Vec3::new(x0, y1, z0);
        let v10 = Vec3::new(x1, y0, z0);
        let v11 = Vec3::new(x1, y1, z0);
        n0 = v00.cross(v10).normalize();
        let n1 = v10.cross(v11).normalize();
        n2 = v11.cross(v01).normalize();
        let n3 = v01.cross(v00).normalize();
        let g01 = corner_angle(n0, n1) + corner_angle(n1, n2);
        let g23 = corner_angle(n2, n3) + corner_angle(n3, n0);
        omega = triangle_solid_angle(v00, v10, v11) + triangle_solid_angle(v00, v11, v01);
        au0 = 0.5 * ((2.0 * PI - g23) + (g01 - omega));
    }
    // NaN (a degenerate rect) also draws by area, as WGSL's negated test.
    if !square || omega.is_nan() || omega < RECT_AREA_SAMPLING_BELOW {
        let to_q = area_point - origin;
        let d2 = to_q.length_squared();
        let cos_l_area = -edge_u.cross(edge_v).dot(to_q) / d2.sqrt();
        out.weight = cos_l_area.max(0.0) / d2;
        return out;
    }
    let (b0, b1) = (n0.z, n2.z);
    let au = au0 + xi.x * omega;
    let fu = (au.cos() * b0 - b1) / au.sin();
    let cu = (wgsl_sign(fu) / (fu * fu + b0 * b0).sqrt()).clamp(-0.999_999_94, 0.999_999_94);
    let xu = (-(cu * z0) / (1.0 - cu * cu).max(0.0).sqrt()).clamp(x0, x1);
    let dd = (xu * xu + z0 * z0).sqrt();
    let h0 = y0 / (dd * dd + y0 * y0).sqrt();
    let h1 = y1 / (dd * dd + y1 * y1).sqrt();
    let hv = h0 + xi.y * (h1 - h0);
    let hv2 = hv * hv;
    let yv = if hv2 < 1.0 - 1.0e-6 {
        hv * dd / (1.0 - hv2).sqrt()
    } else {
        y1
    };
    out.point = origin + xu * ex + yv * ey + z0 * ez;
    out.weight = omega;
    out
}

/// The angle between -a and b (WGSL `corner_angle`).
fn corner_angle(a: Vec3, b: Vec3) -> f32 {
    a.cross(b).length().atan2(-a.dot(b))
}

/// The solid angle of the triangle (a, b, c) seen from the origin (WGSL
/// `triangle_solid_angle`, Van Oosterom and Strackee 1983).
fn triangle_solid_angle(a: Vec3, b: Vec3, c: Vec3) -> f32 {
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let num = a.dot(b.cross(c)).abs();
    let den = la * lb * lc + a.dot(b) * lc + a.dot(c) * lb + b.dot(c) * la;
    2.0 * num.atan2(den)
}

/// WGSL `sign`: 0 at 0 (Rust's `signum` gives 1).
fn wgsl_sign(x: f32) -> f32 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        0.0
    }
}

fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// As WGSL `offset_ray_origin` (Wächter & Binder, Ray Tracing Gems ch. 6).
pub fn offset_ray_origin(p: Vec3, n: Vec3) -> Vec3 {
    const INT_SCALE: f32 = 256.0;
    const FLOAT_SCALE: f32 = 1.0 / 65536.0;
    const ORIGIN: f32 = 1.0 / 32.0;
    let off = |p: f32, n: f32| {
        let of_i = (INT_SCALE * n) as i32;
        let p_i =
            f32::from_bits(
                (p.to_bits() as i32).wrapping_add(if p < 0.0 { -of_i } else { of_i }) as u32,
            );
        if p.abs() < ORIGIN {
            p + FLOAT_SCALE * n
        } else {
            p_i
        }
    };
    Vec3::new(off(p.x, n.x), off(p.y, n.y), off(p.z, n.z))
}

fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

fn texel(t: &Texture, x: i32, y: i32) -> Vec3 {
    let (w, h) = (t.width as i32, t.height as i32);
    let xi = x.rem_euclid(w) as usize;
    let yi = y.rem_euclid(h) as usize;
    let c = t.texels[yi * t.width as usize + xi];
    Vec3::new(
        srgb_to_linear(c[0] as f32 / 255.0),
        srgb_to_linear(c[1] as f32 / 255.0),
        srgb_to_linear(c[2] as f32 / 255.0),
    )
}

/// Bilinear, repeat-wrapped lookup in linear colour (v = 1 is the top row), as WGSL.
pub fn sample_texture(t: &Texture, uv: Vec2) -> Vec3 {
    let x = (uv.x - uv.x.floor()) * t.width as f32 - 0.5;
    let y = (1.0 - (uv.y - uv.y.floor())) * t.height as f32 - 0.5;
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (xi, yi) = (x0 as i32, y0 as i32);
    let top = texel(t, xi, yi).lerp(texel(t, xi + 1, yi), fx);
    let bottom = texel(t, xi, yi + 1).lerp(texel(t, xi + 1, yi + 1), fx);
    top.lerp(bottom, fy)
}

/// Scrambles the choice of one light (WGSL `LIGHT_CHOICE_SEED`).
const LIGHT_CHOICE_SEED: u32 = 0x5e_1ec7;

/// The weight of `light`'s choice at `s` (WGSL `light_choice_weight`): what it gives `s`
/// unoccluded, exactly, up to the sum of its colour channels (a rect light's radiance
/// times [`rect_projected_solid_angle`]); zero exactly where it cannot light `s`.
pub fn light_choice_weight(s: &Surface, light: &Light) -> f32 {
    // NaN (a surface at a point light) weighs nothing, infinity a finite large weight.
    let w = light_choice_weight_raw(s, light);
    if w > 0.0 { w.min(1.0e30) } else { 0.0 }
}

fn light_choice_weight_raw(s: &Surface, light: &Light) -> f32 {
    let n = s.shading_normal;
    let power = |c: Vec3| c.x + c.y + c.z;
    match *light {
        Light::Sun {
            direction,
            irradiance,
        } => power(irradiance) * n.dot(direction.normalize()).max(0.0),
        Light::Rect {
            corner,
            edge_u,
            edge_v,
            radiance,
        } => {
            let a = corner - s.position;
            if edge_u.cross(edge_v).normalize().dot(a) >= 0.0 {
                return 0.0;
            }
            power(radiance) * rect_projected_solid_angle(n, a, edge_u, edge_v)
        }
        Light::Point {
            position,
            intensity,
        }
        | Light::Spot {
            position,
            intensity,
            ..
        } => {
            let to_light = position - s.position;
            let d2 = to_light.dot(to_light);
            let mut cone = 1.0;
            if let Light::Spot {
                direction,
                cos_inner,
                cos_outer,
                ..
            } = *light
            {
                cone = smoothstep(
                    cos_outer,
                    cos_inner,
                    (-to_light / d2.sqrt()).dot(direction.normalize()),
                );
            }
            power(intensity) * cone * n.dot(to_light).max(0.0) / (d2 * d2.sqrt())
        }
    }
}

/// The cosine-weighted solid angle of the parallelogram `a + u b + v c` (relative to the
/// surface) above the plane of normal `n` (WGSL `rect_projected_solid_angle`): Lambert's
/// formula after clipping the polygon to `n.x >= 0`.
pub fn rect_projected_solid_angle(n: Vec3, a: Vec3, b: Vec3, c: Vec3) -> f32 {
    let quad = [a, a + b, a + b + c, a + c];
    let mut clipped = Vec::with_capacity(5);
    for k in 0..4 {
        let (p0, p1) = (quad[k], quad[(k + 1) % 4]);
        let (d0, d1) = (n.dot(p0), n.dot(p1));
        if d0 > 0.0 {
            clipped.push(p0);
        }
        if (d0 > 0.0) != (d1 > 0.0) {
            clipped.push(p0 + (d0 / (d0 - d1)) * (p1 - p0));
        }
    }
    let m = clipped.len();
    if m < 3 {
        return 0.0;
    }
    let mut sum = 0.0f32;
    for k in 0..m {
        let (u0, u1) = (clipped[k].normalize(), clipped[(k + 1) % m].normalize());
        let cr = u0.cross(u1);
        let len = cr.length();
        if len > 0.0 {
            sum += len.atan2(u0.dot(u1)) * (n.dot(cr) / len);
        }
    }
    0.5 * sum.abs()
}

/// The lights a plane hit at `s` samples with `choices` choices (WGSL
/// `shadow_loop_start_chosen`, `shadow_loop_seek`): `None` (every light) when `choices` is 0
/// or at least the number of lights, else each light's factor `t T / (m w)` (0: not
/// sampled), the goals `(xi + c) T / m` falling on the lights by systematic resampling.
pub fn choose_lights(
    lights: &[Light],
    s: &Surface,
    seed: u32,
    first: u32,
    choices: u32,
) -> Option<Vec<f32>> {
    if choices == 0 || choices as usize >= lights.len() {
        return None;
    }
    let weights: Vec<f32> = lights.iter().map(|l| light_choice_weight(s, l)).collect();
    let total = weights.iter().fold(0.0f32, |t, &w| t + w);
    if total <= 0.0 {
        return Some(vec![0.0; lights.len()]);
    }
    let xi = sobol_2d(first, hash_combine(seed, LIGHT_CHOICE_SEED)).x;
    let scale = choices as f32 / total;
    let mut cum = 0.0f32;
    Some(
        weights
            .iter()
            .map(|&w| {
                let before = (cum * scale - xi).ceil();
                cum += w;
                let t = (cum * scale - xi).ceil() - before;
                if w > 0.0 && t > 0.0 {
                    t / (w * scale)
                } else {
                    0.0
                }
            })
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn floor_point() -> Surface {
        Surface {
            position: Vec3::ZERO,
            geometric_normal: Vec3::Y,
            shading_normal: Vec3::Y,
            uv: Vec2::ZERO,
            material: 0,
            front_face: true,
        }
    }

    fn panel(x: f32, facing_down: bool) -> Light {
        let (edge_u, edge_v) = if facing_down {
            (Vec3::Z, -Vec3::X)
        } else {
            (-Vec3::X, Vec3::Z)
        };
        Light::Rect {
            corner: Vec3::new(x, 2.0, 0.0),
            edge_u: 0.5 * edge_u,
            edge_v: 0.5 * edge_v,
            radiance: Vec3::splat(5.0),
        }
    }

    /// Lambert's formula against a midpoint-rule integral of cos_s cos_l / d^2 over the
    /// rect (400 x 400 cells), above the horizon, crossing it, and close to the light.
    #[test]
    fn rect_projected_solid_angle_is_the_integral_of_the_cosines() {
        let b = Vec3::new(0.0, 0.0, 0.4);
        let c = Vec3::new(-0.8, 0.0, 0.0);
        let nl = b.cross(c).normalize();
        for (p, n) in [
            (Vec3::new(0.3, -1.5, 0.2), Vec3::Y),
            (Vec3::new(0.3, -1.5, 0.2), Vec3::new(0.6, 0.8, 0.0)),
            (Vec3::new(-0.4, -0.3, 0.2), Vec3::new(1.0, 0.0, 0.0)),
            (
                Vec3::new(-0.7, -0.05, -0.1),
                Vec3::new(0.0, 0.2, 1.0).normalize(),
            ),
        ] {
            let a = -p;
            let k = 400;
            let mut integral = 0.0f64;
            for i in 0..k {
                for j in 0..k {
                    let d =
                        a + ((i as f32 + 0.5) / k as f32) * b + ((j as f32 + 0.5) / k as f32) * c;
                    let d2 = d.dot(d);
                    let cs = (n.dot(d) / d2.sqrt()).max(0.0);
                    let cl = (-nl.dot(d) / d2.sqrt()).max(0.0);
                    integral += f64::from(cs * cl / d2);
                }
            }
            integral *= f64::from(b.cross(c).length()) / f64::from(k * k);
            let lambert = f64::from(rect_projected_solid_angle(n, a, b, c));
            assert!(
                (lambert - integral).abs() <= 0.01 * integral,
                "p {p}, n {n}: Lambert {lambert}, integral {integral}"
            );
        }
    }

    /// Rect samples drawn by solid angle estimate the unoccluded irradiance (Lambert's
    /// formula) within 1 % from 1,024 Sobol points, for a receiver far from the panel, one
    /// beside it and one 1 mm under it, where area sampling's weights cos_l A / d^2 pass
    /// a thousand: no solid-angle sample weighs more than the 2 pi a visible
    /// rect can subtend, and every point lies on the rect. A parallelogram is drawn by area
    /// (its estimate as unbiased). A receiver behind the panel, or in its plane, gets
    /// weight 0.
    #[test]
    fn rect_samples_by_solid_angle_are_bounded_and_unbiased() {
        let a = Vec3::new(-0.5, 1.0, -0.25);
        let (b, c) = (Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 0.5));
        let nl = b.cross(c).normalize();
        assert!(nl.y < 0.0, "the panel faces down");
        let count = 1024;
        for (p, n) in [
            (Vec3::new(0.2, -3.0, 0.4), Vec3::Y),
            (
                Vec3::new(0.8, 0.9, 0.0),
                Vec3::new(-1.0, 0.2, 0.0).normalize(),
            ),
            (Vec3::new(0.1, 0.999, -0.1), Vec3::Y),
        ] {
            let (mut sum, mut area_max, mut max_weight) = (0.0f64, 0.0f32, 0.0f32);
            for k in 0..count {
                let xi = sobol_2d(k, 77);
                let rs = rect_light_sample(a, b, c, p, xi);
                let l = (rs.point - p).normalize();
                sum += f64::from(n.dot(l).max(0.0) * rs.weight);
                max_weight = max_weight.max(rs.weight);
                let q = a + xi.x * b + xi.y * c;
                let d = q - p;
                area_max = area_max.max(-nl.dot(d) * b.cross(c).length() / d.length().powi(3));
                let on = rs.point - a;
                let (u, v) = (
                    on.dot(b) / b.length_squared(),
                    on.dot(c) / c.length_squared(),
                );
                assert!(
                    (-1e-4..=1.0 + 1e-4).contains(&u)
                        && (-1e-4..=1.0 + 1e-4).contains(&v)
                        && on.dot(nl).abs() < 1e-4,
                    "p {p}: sample {k} at {} is off the rect",
                    rs.point
                );
            }
            let estimate = sum / f64::from(count);
            let exact = f64::from(rect_projected_solid_angle(n, a - p, b, c));
            assert!(
                (estimate - exact).abs() <= 0.01 * exact,
                "p {p}: estimate {estimate}, Lambert {exact}"
            );
            assert!(
                max_weight <= 2.0 * PI,
                "p {p}: a sample weighs {max_weight}"
            );
            if p.y > 0.99 {
                assert!(
                    area_max > 1.0e3,
                    "by area the weights reach only {area_max}"
                );
            }
        }
        // A parallelogram is drawn by area: the same points and weights as the quad's
        // area sampling, and the same unbiased estimate from afar.
        let skew = Vec3::new(0.3, 0.0, 0.5);
        let p = Vec3::new(0.2, -3.0, 0.4);
        let mut sum = 0.0f64;
        for k in 0..count {
            let xi = sobol_2d(k, 78);
            let rs = rect_light_sample(a, b, skew, p, xi);
            let q = a + xi.x * b + xi.y * skew;
            let d = q - p;
            let by_area = -b.cross(skew).dot(d) / d.length().powi(3);
            assert_eq!(rs.point, q, "sample {k}");
            assert!((rs.weight - by_area).abs() <= 1e-6 * by_area, "sample {k}");
            sum += f64::from(Vec3::Y.dot(d.normalize()).max(0.0) * rs.weight);
        }
        let exact = f64::from(rect_projected_solid_angle(Vec3::Y, a - p, b, skew));
        let estimate = sum / f64::from(count);
        assert!(
            (estimate - exact).abs() <= 0.01 * exact,
            "parallelogram: estimate {estimate}, Lambert {exact}"
        );
        for behind in [Vec3::new(0.0, 1.5, 0.0), Vec3::new(3.0, 1.0, 0.0)] {
            let rs = rect_light_sample(a, b, c, behind, Vec2::splat(0.5));
            assert_eq!(rs.weight, 0.0, "{behind}");
        }
    }

    /// Over 4,096 consecutive sequence indices each light that can light the point has a
    /// mean factor of 1 (within 1 %: the choice is unbiased and stratified), with one
    /// choice and with two; with one its share of the choices is its share of the weight;
    /// lights that cannot light the point (a panel facing away, a sun below the horizon)
    /// weigh zero and are never sampled; a light above half the weight is sampled at
    /// every index with two choices.
    #[test]
    fn lights_are_chosen_in_proportion_to_their_weight() {
        let s = floor_point();
        let lights = [
            panel(0.0, true),
            panel(3.0, true),
            panel(1.0, false),
            Light::Point {
                position: Vec3::new(-1.0, 1.0, 0.5),
                intensity: Vec3::splat(2.0),
            },
            Light::Sun {
                direction: Vec3::new(0.0, -1.0, 0.2).normalize(),
                irradiance: Vec3::splat(10.0),
            },
        ];
        let w: Vec<f32> = lights.iter().map(|l| light_choice_weight(&s, l)).collect();
        assert!(w[0] > w[1] && w[1] > 0.0 && w[3] > 0.0, "weights {w:?}");
        assert_eq!((w[2], w[4]), (0.0, 0.0), "weights {w:?}");
        let total: f32 = w.iter().sum();
        assert!(
            w[3] > 0.5 * total,
            "weights {w:?}: the test wants a dominant light"
        );
        let n = 4096;
        for choices in [1u32, 2, 3] {
            let mut sampled = [0usize; 5];
            let mut factor_sum = [0.0f64; 5];
            for first in 0..n {
                let f = choose_lights(&lights, &s, 9, first, choices).expect("several lights");
                for i in 0..lights.len() {
                    sampled[i] += usize::from(f[i] > 0.0);
                    factor_sum[i] += f64::from(f[i]);
                }
                if choices == 1 {
                    assert_eq!(f.iter().filter(|&&x| x > 0.0).count(), 1, "index {first}");
                } else {
                    assert!(f[3] > 0.0, "index {first}: the dominant light was missed");
                }
            }
            for i in 0..lights.len() {
                let mean = factor_sum[i] / f64::from(n);
                if w[i] == 0.0 {
                    assert_eq!(sampled[i], 0, "light {i} cannot light the point");
                } else {
                    assert!(
                        (mean - 1.0).abs() <= 0.01,
                        "{choices} choices, light {i}: mean factor {mean}"
                    );
                }
                if choices == 1 {
                    let share = sampled[i] as f32 / n as f32;
                    assert!(
                        (share - w[i] / total).abs() <= 0.005,
                        "light {i}: chosen {share}, weight share {}",
                        w[i] / total
                    );
                }
            }
        }
        let at_point = Light::Point {
            position: s.position,
            intensity: Vec3::ONE,
        };
        assert_eq!(
            light_choice_weight(&s, &at_point),
            0.0,
            "NaN weighs nothing"
        );
        assert_eq!(choose_lights(&lights, &s, 9, 0, 0), None, "0: every light");
        assert_eq!(
            choose_lights(&lights, &s, 9, 0, 5),
            None,
            "as many as lights: every light"
        );
        assert_eq!(
            choose_lights(&[lights[2].clone(), lights[4].clone()], &s, 9, 0, 1),
            Some(vec![0.0, 0.0]),
            "no light can light the point: none sampled"
        );
    }
}
