//! `relight verify nearfield`'s fixed-view specular rows
//! ([`crate::specular`]): a glossy scene (a GGX-over-diffuse sphere, RGB
//! transport, on a Phong floor, one channel; [`glossy_floor_and_sphere`])
//! under the textured ceiling light with shadows, from the scene camera's
//! fixed view, against the Monte Carlo reference: the error ladder (exact
//! per-vertex light with the BRDF at the vertex's view, Gouraud → face
//! clipped → the method uncompressed → 1 %/20 % and other compressions),
//! the image target of issue 13 (≤ 0.08 relative RMS at 1 %/20 %), and the
//! per-vertex accuracy against face-clipped quadrature of the box-averaged
//! light (report).

use crate::face::LightFrame;
use crate::light::light_cells;
use crate::method::{NearfieldMethod, NearfieldOptions};
use crate::scenes::glossy_floor_and_sphere;
use crate::specular::{ObjectKind, VertexBrdf, local_view, vertex_frame};
use crate::verify::{VerifyOptions, VerifyRow, fail};
use crate::verify_judge::{ImageJudge, image_row};
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use relight_render::method::Relighter;

use relight_render::verify_row::row;
use relight_render::{AreaLight, Object, Progress, Scene, SceneBvh};
use relight_sphere::Frame;

/// `∫_face L f(ω_o, ω) cos V dω` at a vertex by `samples²` midpoints over
/// the light's footprint on the face (as [`crate::verify::face_quadrature`],
/// with the BRDF at the fixed view `wo`, local to `shading`).
#[allow(clippy::too_many_arguments)]
#[must_use]
pub fn face_quadrature_brdf(
    frame: &LightFrame,
    face: f64,
    p: Vec3,
    shading: &Frame,
    wo: Vec3,
    brdf: VertexBrdf,
    samples: usize,
    radiance: &(dyn Fn(Vec2) -> Vec3 + Sync),
    bvh: Option<&SceneBvh>,
) -> Vec3 {
    let radiance = |uv: Vec2, _: Vec3| radiance(uv);
    crate::verify::face_quadrature_with(frame, face, p, shading.z, samples, &radiance, bvh, |w| {
        brdf_weight(shading, wo, brdf, w)
    })
}

/// `f(ω_o, ω) cos θ` for the unit world direction `w` (zero below the
/// horizon of `shading`).
fn brdf_weight(shading: &Frame, wo: Vec3, brdf: VertexBrdf, w: Vec3) -> Vec3 {
    let wi = shading.to_local(w);
    if wi.z <= 0.0 {
        Vec3::ZERO
    } else {
        brdf.eval(wo, wi) * wi.z
    }
}

/// `∫_light L f(ω_o, ω) cos V dω` at a vertex by `samples²` midpoints over
/// the light's area (the whole light, true texture).
#[must_use]
pub fn area_quadrature_brdf(
    light: &AreaLight,
    p: Vec3,
    shading: &Frame,
    wo: Vec3,
    brdf: VertexBrdf,
    samples: usize,
    bvh: Option<&SceneBvh>,
) -> Vec3 {
    crate::verify::area_quadrature_with(light, p, shading.z, samples, bvh, |w| {
        brdf_weight(shading, wo, brdf, w)
    })
}

/// The BRDF of `object` at vertex `v` (its blend weight applied).
#[must_use]
pub fn vertex_brdf(object: &Object, v: usize) -> VertexBrdf<'_> {
    VertexBrdf {
        first: object.brdf.as_ref(),
        second: object.blend.as_ref().map(|b| {
            let uv = object.mesh.uvs.get(v).copied().unwrap_or(Vec2::ZERO);
            (b.second.as_ref(), b.weight_at(uv))
        }),
    }
}

/// Exitant radiance towards the scene camera's eye of every vertex by
/// quadrature: over the light's area (`face = None`) or face-clipped with
/// `radiance` (`Some(face)`). Lambertian objects read their albedo.
fn quadrature_colors(
    scene: &Scene,
    face: Option<f64>,
    samples: usize,
    radiance: &(dyn Fn(Vec2) -> Vec3 + Sync),
    bvh: Option<&SceneBvh>,
) -> Vec<Vec<Vec3>> {
    let light = &scene.area_lights[0];
    let frame = LightFrame::of(light);
    let eye = scene.camera.eye;
    scene
        .objects
        .iter()
        .map(|o| {
            let m = &o.mesh;
            (0..m.positions.len())
                .into_par_iter()
                .map(|v| {
                    let p = m.positions[v];
                    let shading = vertex_frame(m.normals[v], m.tangents.get(v).copied());
                    let wo = local_view(&shading, p, eye);
                    let brdf = vertex_brdf(o, v);
                    match face {
                        None => area_quadrature_brdf(light, p, &shading, wo, brdf, samples, bvh),
                        Some(f) => face_quadrature_brdf(
                            &frame, f, p, &shading, wo, brdf, samples, radiance, bvh,
                        ),
                    }
                })
                .collect()
        })
        .collect()
}

/// Relative error figures per vertex: (max over vertices whose value is
/// ≥ 5 % of the largest, pooled relative RMS).
#[must_use]
pub fn vertex_errors(got: &[Vec3], want: &[Vec3]) -> (f64, f64) {
    let top = want.iter().map(|w| w.max_element()).fold(0.0f32, f32::max);
    let (mut num, mut den, mut max) = (0.0f64, 0.0f64, 0.0f64);
    for (g, w) in got.iter().zip(want) {
        num += f64::from((*g - *w).length_squared());
        den += f64::from(w.length_squared());
        if w.max_element() >= 0.05 * top {
            max = max.max(f64::from((*g - *w).length() / w.length()));
        }
    }
    (max, (num / den.max(1e-30)).sqrt())
}

/// The fixed-view specular rows (module docs).
///
/// # Errors
/// A method or reference failure, as text.
pub fn specular_rows(
    opts: &VerifyOptions,
    progress: &dyn Progress,
) -> Result<Vec<VerifyRow>, String> {
    const ISSUE: &str = "issue 13 (verify nearfield: fixed-view specular)";
    let mut rows = Vec::new();
    let scene = glossy_floor_and_sphere(opts.floor, opts.segments, opts.width, opts.height, true);
    let light = scene.area_lights[0].clone();
    let nf = NearfieldOptions::default();
    let mut m = NearfieldMethod::new(NearfieldOptions {
        source_terms: 1.0,
        target_terms: 1.0,
        ..nf
    })
    .map_err(fail)?;
    let t0 = std::time::Instant::now();
    m.prepare(&scene, progress).map_err(fail)?;
    let prepare_s = t0.elapsed().as_secs_f64();
    let kinds = m.kinds();
    let kind_text = |k: &ObjectKind| match k {
        ObjectKind::Specular { tint: None } => "fixed view, RGB",
        ObjectKind::Specular { tint: Some(_) } => "fixed view, one channel",
        _ => "Lambertian",
    };
    rows.push(row(
        format!(
            "glossy scene: sphere (GGX α 0.25 over diffuse) {}, floor (Phong 20) {}: fixed-view bake (s, wall; whole prepare {prepare_s:.1} s)",
            kind_text(&kinds[0]),
            kind_text(&kinds[1])
        ),
        m.specular_bake_s,
        "seconds",
        None,
        ISSUE,
    ));
    // Per vertex against face-clipped quadrature of the box-averaged light.
    let frame = LightFrame::of(&light);
    let n = nf.order;
    let cells = light_cells(&light, n);
    let boxed = |uv: Vec2| -> Vec3 {
        let x = ((uv.x * n as f32) as usize).min(n - 1);
        let y = ((uv.y * n as f32) as usize).min(n - 1);
        let k = y * n + x;
        Vec3::new(cells[0][k] as f32, cells[1][k] as f32, cells[2][k] as f32)
    };
    let meshes: Vec<_> = scene.objects.iter().map(|o| o.mesh.as_ref()).collect();
    let bvh = SceneBvh::build(&meshes);
    for (oi, o) in scene.objects.iter().enumerate() {
        let vs = o.mesh.positions.len();
        let step = (vs / opts.vertices).max(1);
        let picked: Vec<usize> = (0..vs)
            .step_by(step)
            .filter(|&v| frame.local(o.mesh.positions[v]).z > 0.0)
            .collect();
        let want: Vec<Vec3> = picked
            .par_iter()
            .map(|&v| {
                let p = o.mesh.positions[v];
                let shading = vertex_frame(o.mesh.normals[v], o.mesh.tangents.get(v).copied());
                let wo = local_view(&shading, p, scene.camera.eye);
                face_quadrature_brdf(
                    &frame,
                    nf.face,
                    p,
                    &shading,
                    wo,
                    vertex_brdf(o, v),
                    opts.samples,
                    &boxed,
                    Some(&bvh),
                )
            })
            .collect();
        let got: Vec<Vec3> = picked.iter().map(|&v| m.vertex_colors()[oi][v]).collect();
        let (max, rms) = vertex_errors(&got, &want);
        rows.push(row(
            format!(
                "per vertex, glossy {} ({}), order {n}, 100 %/100 %, shadows: max relative error (lit vertices) / pooled relative RMS {rms:.4} vs face-clipped quadrature",
                if oi == 0 { "sphere" } else { "floor" },
                kind_text(&kinds[oi])
            ),
            max,
            "relative",
            None,
            ISSUE,
        ));
    }
    if opts.per_vertex_only {
        return Ok(rows);
    }
    let (judge, frame0) = ImageJudge::new(&mut m, &scene, opts, 13, progress)?;
    rows.push(judge.noise_row("glossy: "));
    let samples = opts.image_samples;
    let radiance = |uv: Vec2| light.radiance_at(uv);
    let e_gouraud = judge.colors_error(
        &mut m,
        &scene,
        quadrature_colors(&scene, None, samples, &radiance, Some(&bvh)),
        progress,
    )?;
    let e_face = judge.colors_error(
        &mut m,
        &scene,
        quadrature_colors(
            &scene,
            Some(nf.face),
            samples * 3 / 2,
            &radiance,
            Some(&bvh),
        ),
        progress,
    )?;
    for (what, e) in [
        (
            "exact per-vertex light (area quadrature, shadows, BRDF at the vertex's view), Gouraud: Gouraud + σ_MC".to_string(),
            e_gouraud,
        ),
        (
            format!("face-clipped exact per-vertex (face {}): + face truncation", nf.face),
            e_face,
        ),
        (
            format!("nearfield order {} 100 %/100 %: + discretisation", nf.order),
            judge.error(&frame0),
        ),
    ] {
        rows.push(image_row(format!("glossy image: {what}"), e, None, ISSUE));
    }
    for (s, t) in [
        (0.01, 0.20),
        (0.01, 1.0),
        (1.0, 0.20),
        (0.05, 0.40),
        (0.20, 0.70),
    ] {
        m.set_compression(s, t);
        m.set_lighting(&scene, progress).map_err(fail)?;
        let main = s == 0.01 && t == 0.20;
        rows.push(image_row(
            format!(
                "glossy image: nearfield {:.0} %/{:.0} %{}",
                s * 100.0,
                t * 100.0,
                if main { ": + compression" } else { "" }
            ),
            judge.render_error(&mut m, &scene, progress)?,
            main.then_some(0.08),
            ISSUE,
        ));
    }
    rows.push(image_row(
        "glossy image: nearfield 1 %/20 %, sources ranked by magnitude (default: area-weighted)",
        judge.magnitude_ranked_error(&mut m, &scene, progress)?,
        None,
        ISSUE,
    ));
    Ok(rows)
}
