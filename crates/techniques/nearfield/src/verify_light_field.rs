//! `relight verify nearfield`'s light-field rows ([`crate::light_field`],
//! thesis eq. 4.37, optional in issue 13, so reported without targets): the
//! floor and sphere under the ceiling light seen through the built-in prism
//! field ([`floor_and_sphere_light_field`], 4 × 4 views).
//!
//! * Per vertex, uncompressed, unshadowed, against face-clipped quadrature
//!   of the field's radiance by direction with each view box-averaged at
//!   the method's order ([`boxed_field_radiance`]): views on face cells
//!   (extent 2, exact in the basis) and off them (extent 1.7, each face
//!   cell taking its angular atoms' means).
//! * The image with shadows against the reference of the same field: the
//!   error ladder (exact per-vertex light, Gouraud → face-clipped → the
//!   method uncompressed → 1 %/20 %), and the angular slices 1 %/20 % keeps.

use crate::face::LightFrame;
use crate::light::light_cells;
use crate::method::{NearfieldMethod, NearfieldOptions};
use crate::scenes::floor_and_sphere_light_field;
use crate::verify::{
    VerifyOptions, VerifyRow, exact_rungs, face_quadrature_directional, fail, vertex_errors,
};
use crate::verify_judge::{ImageJudge, image_row};
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use relight_render::method::Relighter;
use relight_render::verify_row::row;
use relight_render::{AreaLight, Progress, Scene};

const SOURCE: &str = "sun-thesis-2008 §4.5.3, eq. 4.37 (optional in issue 13: reported)";

/// `light`'s radiance by direction (`radiance(uv, ω)`, `ω` towards the
/// light) with each view of its field box-averaged on an `n × n` grid: what
/// the method represents exactly, so that a comparison isolates the
/// transport's and the angular atoms' discretisation. A light without a
/// field: its texture box-averaged.
pub fn boxed_field_radiance(light: &AreaLight, n: usize) -> impl Fn(Vec2, Vec3) -> Vec3 + Sync {
    let (a, views) = match &light.light_field {
        Some(lf) => {
            let a = lf.views();
            let views: Vec<[Vec<f64>; 3]> = (0..a * a)
                .map(|v| {
                    let mut l = light.clone();
                    l.light_field = None;
                    l.texture = Some(std::sync::Arc::new(lf.view(v % a, v / a).clone()));
                    light_cells(&l, n)
                })
                .collect();
            (a, views)
        }
        None => (1, vec![light_cells(light, n)]),
    };
    let light = light.clone();
    move |uv: Vec2, wi: Vec3| -> Vec3 {
        let view = match &light.light_field {
            None => 0,
            Some(lf) => {
                let m = light.world_from_light;
                let cos = -wi.dot(m.z_axis);
                if cos <= 0.0 {
                    return Vec3::ZERO;
                }
                let slope = Vec2::new(-wi.dot(m.x_axis), -wi.dot(m.y_axis)) / cos;
                match lf.view_of(slope) {
                    Some((ax, ay)) => ay * a + ax,
                    None => return Vec3::ZERO,
                }
            }
        };
        let c = &views[view];
        let x = ((uv.x * n as f32) as usize).min(n - 1);
        let y = ((uv.y * n as f32) as usize).min(n - 1);
        let k = y * n + x;
        Vec3::new(c[0][k] as f32, c[1][k] as f32, c[2][k] as f32)
    }
}

/// The method with every source and target term, prepared for `scene`.
fn prepared_uncompressed(
    scene: &Scene,
    progress: &dyn Progress,
) -> Result<NearfieldMethod, String> {
    let mut m = NearfieldMethod::new(NearfieldOptions {
        source_terms: 1.0,
        target_terms: 1.0,
        ..NearfieldOptions::default()
    })
    .map_err(fail)?;
    m.prepare(scene, progress).map_err(fail)?;
    Ok(m)
}

/// The rows (module docs).
///
/// # Errors
/// A method or reference failure, as text.
pub(crate) fn light_field_rows(
    opts: &VerifyOptions,
    progress: &dyn Progress,
) -> Result<Vec<VerifyRow>, String> {
    let mut rows = Vec::new();
    let size = [opts.width, opts.height];
    for (extent, what) in [
        (2.0f32, "views on face cells"),
        (1.7, "views off face cells"),
    ] {
        let scene = floor_and_sphere_light_field(opts.floor, opts.segments, size, false, 4, extent);
        let m = prepared_uncompressed(&scene, progress)?;
        let light = &scene.area_lights[0];
        let frame = LightFrame::of(light);
        let radiance = boxed_field_radiance(light, m.options().order);
        let albedos = m.albedos();
        let (mut got, mut want) = (Vec::new(), Vec::new());
        for (oi, o) in scene.objects.iter().enumerate() {
            let vs = o.mesh.positions.len();
            let picked: Vec<usize> = (0..vs)
                .step_by((vs / opts.vertices).max(1))
                .filter(|&v| frame.local(o.mesh.positions[v]).z > 0.0)
                .collect();
            let k = albedos[oi] / std::f32::consts::PI;
            let q: Vec<Vec3> = picked
                .par_iter()
                .map(|&v| {
                    k * face_quadrature_directional(
                        &frame,
                        m.options().face,
                        o.mesh.positions[v],
                        o.mesh.normals[v],
                        opts.samples,
                        &radiance,
                        None,
                    )
                })
                .collect();
            for (&v, w) in picked.iter().zip(q) {
                got.push(m.vertex_colors()[oi][v]);
                want.push(w);
            }
        }
        let (max, rms) = vertex_errors(&got, &want);
        rows.push(row(
            format!("light field 4 × 4 views, extent {extent} ({what}), per vertex, order {}, 100 %/100 %, unshadowed: max relative error (lit vertices) vs face-clipped quadrature by direction", m.options().order),
            max,
            "relative",
            None,
            SOURCE,
        ));
        rows.push(row(
            format!("light field, extent {extent}: pooled relative RMS vs the same quadrature"),
            rms,
            "relative",
            None,
            SOURCE,
        ));
    }
    if opts.per_vertex_only {
        return Ok(rows);
    }
    let scene = floor_and_sphere_light_field(opts.floor, opts.segments, size, true, 4, 2.0);
    let mut m = prepared_uncompressed(&scene, progress)?;
    let (judge, frame0) = ImageJudge::new(&mut m, &scene, opts, 23, progress)?;
    rows.push(judge.noise_row("light field: "));
    let [e_gouraud, e_face] = exact_rungs(&judge, &mut m, &scene, opts, progress)?;
    for (e, what) in [
        (
            e_gouraud,
            "exact per-vertex light by direction (area quadrature, shadows), Gouraud",
        ),
        (e_face, "face-clipped exact per-vertex: + face truncation"),
        (
            judge.error(&frame0),
            "nearfield 100 %/100 %: + discretisation",
        ),
    ] {
        rows.push(image_row(
            format!("image, light field: {what}"),
            e,
            None,
            SOURCE,
        ));
    }
    // The default compression keeps as many terms as of a plain light
    // (`crate::light_field`); then 4× and 16× that budget.
    let d = NearfieldOptions::default();
    for scale in [1.0, 4.0, 16.0] {
        let s = d.source_terms * scale;
        m.set_compression(s, d.target_terms);
        m.set_lighting(&scene, progress).map_err(fail)?;
        let what = if scale == 1.0 {
            ": + compression (the default)".to_string()
        } else {
            format!(" ({scale}× the default's source terms)")
        };
        rows.push(image_row(
            format!(
                "image, light field: nearfield {:.0} %/{:.0} %{what}, {} of 16 angular slices kept",
                s * 100.0,
                d.target_terms * 100.0,
                m.field_slices(0)
            ),
            judge.render_error(&mut m, &scene, progress)?,
            None,
            SOURCE,
        ));
    }
    Ok(rows)
}
