//! The fog method through the method interface: its point-light part is
//! `render_fog`, its environment part at β = 0 is plain SH shading, in fog
//! the environment part matches the closed form of a uniform sky, the
//! empty-pixel airlight to the fog ball's edge matches eq. 3.5 integrated
//! numerically, and unsupported features are `check_scene` errors.

use glam::{Vec2, Vec3};
use relight_brdf::Lambert;
use relight_fog::method::ENVIRONMENT_APPROXIMATION;
use relight_fog::render::floor_grid;
use relight_fog::special::airlight_eq35;
use relight_fog::{FogOptions, FogRelighter, FogSettings, FogTables, render_fog, scene_objects};
use relight_render::method::{
    FrameRequest, MethodError, Relighter, SceneFeature, check_scene, frame_paints_background,
    render_frame,
};
use relight_render::{AreaLight, Camera, Image, Medium, NoProgress, Object, PointLight, Scene};
use relight_sphere::{EnvMap, Param};
use std::sync::Arc;

fn camera(width: usize, height: usize) -> Camera {
    Camera {
        eye: Vec3::new(0.0, 1.5, 5.0),
        target: Vec3::new(0.0, 0.5, 0.0),
        up: Vec3::Y,
        vfov_deg: 40.0,
        width,
        height,
        image_offset: glam::Vec2::ZERO,
    }
}

fn sky(scale: f32) -> EnvMap {
    EnvMap::from_fn(
        Param::LatLong {
            width: 32,
            height: 16,
        },
        |d| Vec3::new(0.4, 0.5, 0.7) * (1.0 + d.y).max(0.0) * scale + Vec3::splat(0.05 * scale),
    )
}

fn lambert(a: f32) -> Arc<dyn relight_brdf::Brdf> {
    Arc::new(Lambert::new(Vec3::splat(a)).unwrap())
}

/// A sphere on a floor, two point lights, the given environment and medium.
fn scene(env: EnvMap, medium: Option<Medium>) -> Scene {
    let sphere = relight_geom::shapes::uv_sphere_at(Vec3::new(0.0, 0.6, 0.0), 0.6, 48, 24);
    let floor = floor_grid(0.0, 3.0, 8);
    let mut s = Scene::new(
        vec![
            Object::new(Arc::new(floor), lambert(0.6)),
            Object::new(Arc::new(sphere), lambert(0.8)),
        ],
        env,
        camera(40, 24),
    );
    s.point_lights = vec![
        PointLight::new(Vec3::new(-1.5, 2.0, 1.0), Vec3::splat(10.0)),
        PointLight::new(Vec3::new(1.2, 1.4, 0.8), Vec3::new(4.0, 3.0, 2.0)),
    ];
    s.medium = medium;
    s
}

fn black() -> EnvMap {
    sky(0.0)
}

fn fog(beta: f32, albedo: f32, radius: f32) -> Option<Medium> {
    Some(Medium {
        beta,
        albedo,
        radius,
    })
}

fn render(method: &mut FogRelighter, scene: &Scene, aa: usize) -> Image {
    method.prepare(scene, &NoProgress).unwrap();
    method
        .render(
            scene,
            &FrameRequest::new(scene.camera).with_aa(aa),
            &NoProgress,
        )
        .unwrap()
        .image
}

fn max_rel_diff(a: &Image, b: &Image) -> f32 {
    assert_eq!((a.width, a.height), (b.width, b.height));
    let peak = b.pixels.iter().fold(0.0f32, |m, p| m.max(p.max_element()));
    a.pixels
        .iter()
        .zip(&b.pixels)
        .map(|(x, y)| (*x - *y).abs().max_element())
        .fold(0.0f32, f32::max)
        / peak.max(1e-30)
}

#[test]
fn point_light_part_is_render_fog() {
    let s = scene(black(), fog(0.08, 0.7, 12.0));
    let mut m = FogRelighter::new(FogOptions::default()).unwrap();
    let objects = scene_objects(&s);
    let tables = FogTables::build_for(64, objects.iter().map(|o| &o.material)).unwrap();
    let mut settings = FogSettings::new(&tables, 0.08);
    settings.albedo = 0.7;
    settings.ball_radius = Some(12.0);
    let lights: Vec<relight_fog::PointLight> = s
        .point_lights
        .iter()
        .map(|l| relight_fog::PointLight::new(l.position, l.intensity))
        .collect();
    for aa in [1usize, 2] {
        let mut cam = s.camera;
        cam.width *= aa;
        cam.height *= aa;
        let want = render_fog(&objects, &cam, &lights, &settings)
            .unwrap()
            .box_downsample(aa);
        let got = render(&mut m, &s, aa);
        let e = max_rel_diff(&got, &want);
        assert!(e < 1e-6, "aa={aa}: method vs render_fog differ by {e}");
    }
    // The frame reports its own coverage: the sphere and floor fill the
    // lower image, the top row is sky.
    let r = m
        .render(&s, &FrameRequest::new(s.camera), &NoProgress)
        .unwrap();
    let c = r.coverage.unwrap();
    assert_eq!(c.coverage.len(), 40 * 24);
    assert_eq!(c.coverage[0], 0.0);
    assert_eq!(c.coverage[40 * 23 + 20], 1.0);
    assert!(c.object_id.contains(&2), "sphere pixels carry object id 2");
}

#[test]
fn without_fog_the_environment_part_is_plain_sh_shading() {
    // The per-pixel environment part (the per-vertex one is compared with
    // it in `env_vertex`).
    let opts = FogOptions {
        env_shading: relight_fog::EnvShading::PerPixel,
        ..FogOptions::default()
    };
    for medium in [None, fog(0.0, 1.0, 10.0)] {
        let mut s = scene(sky(1.0), medium);
        s.point_lights.clear();
        let mut m = FogRelighter::new(opts).unwrap();
        let got = render(&mut m, &s, 1);
        let want = relight_shlight::ShRenderer::new(opts.env_order, opts.env_rotation)
            .unwrap()
            .render(&s, None, &NoProgress)
            .unwrap()
            .image;
        let e = max_rel_diff(&got, &want);
        assert!(e < 1e-6, "{medium:?}: fog method vs plain SH differ by {e}");
    }
}

/// Without a medium `render_frame` paints every pixel no object covers, so
/// the per-vertex environment pass shades only the empty samples of
/// partly covered pixels (none at one sample per pixel). The frame stays
/// within 10⁻³ of the peak of the one of a medium too thin to matter
/// (β = 10⁻¹²: the method shades every empty sample and `render_frame`
/// paints nothing), at one and at 2 × 2 samples per pixel: silhouette
/// pixels keep their sky (black empty samples there differ by 0.6).
#[test]
fn a_frame_without_a_medium_shades_only_the_empty_samples_it_shows() {
    let thin = fog(1e-12, 1.0, 50.0);
    for aa in [1usize, 2] {
        let mut frames = Vec::new();
        for medium in [None, thin] {
            let mut s = scene(sky(1.0), medium);
            s.point_lights.clear();
            assert_eq!(frame_paints_background(&s), medium.is_none());
            let mut m = FogRelighter::new(FogOptions::default()).unwrap();
            m.prepare(&s, &NoProgress).unwrap();
            let r = render_frame(
                &mut m,
                &s,
                &FrameRequest::new(s.camera).with_aa(aa),
                &NoProgress,
            )
            .unwrap();
            let partly = r
                .coverage
                .as_ref()
                .unwrap()
                .coverage
                .iter()
                .filter(|&&c| c > 0.0 && c < 1.0)
                .count();
            assert!(
                aa == 1 || partly > 10,
                "aa {aa}: {partly} silhouette pixels"
            );
            frames.push(r.image);
        }
        let e = max_rel_diff(&frames[0], &frames[1]);
        assert!(e < 1e-3, "aa {aa}: no medium vs β = 1e-12 differ by {e}");
    }
}

/// The frame's work count (`Relighter::frame_work`, `relight_fog::work`)
/// follows what the frame shaded: one light fewer removes exactly one
/// light's evaluations of every covered sample and every ball-edge sample,
/// and with the eye outside the ball, of every entry into it too (every
/// covered sample and every empty one whose ray meets the ball).
#[test]
fn frame_work_counts_the_light_evaluations() {
    for eye_outside in [false, true] {
        light_evaluations_counted(eye_outside);
    }
}

fn light_evaluations_counted(eye_outside: bool) {
    use relight_fog::work::{EDGE_EVAL_OPS, SURFACE_EVAL_OPS};
    let mut works = Vec::new();
    let mut covered = 0;
    let radius = if eye_outside { 4.0 } else { 12.0 };
    let mut entering = 0;
    for lights in [2usize, 1] {
        let mut s = scene(sky(1.0), fog(0.08, 0.7, radius));
        s.point_lights.truncate(lights);
        if eye_outside {
            s.camera.vfov_deg = 70.0;
            let rays = s.camera.ray_frame();
            entering = (0..40 * 24)
                .filter(|&i| {
                    let d = rays.dir((i % 40) as f32 + 0.5, (i / 40) as f32 + 0.5);
                    s.medium
                        .unwrap()
                        .ball_span(s.camera.eye, d)
                        .is_some_and(|(t_in, _)| t_in > 0.0)
                })
                .count();
            assert!(entering < 40 * 24, "some rays miss the ball");
        }
        let mut m = FogRelighter::new(FogOptions::default()).unwrap();
        m.prepare(&s, &NoProgress).unwrap();
        let request = FrameRequest::new(s.camera);
        assert!(m.frame_work(&s, &request).is_none(), "no frame yet");
        let r = m.render(&s, &request, &NoProgress).unwrap();
        covered = r
            .coverage
            .unwrap()
            .coverage
            .iter()
            .filter(|&&c| c == 1.0)
            .count();
        works.push(m.frame_work(&s, &request).expect("counted").view_fma);
    }
    let empty = 40 * 24 - covered;
    // Entering rays: the covered samples' (each meets the ball first) and
    // the empty ones'.
    let entries = if eye_outside { entering } else { 0 };
    let one_light = covered as f64 * SURFACE_EVAL_OPS + (empty + entries) as f64 * EDGE_EVAL_OPS;
    assert!(covered > 100 && empty > 10, "{covered} covered");
    assert!(
        (works[0] - works[1] - one_light).abs() < 1e-6 * works[0],
        "{works:?}: one light is {one_light}"
    );
}

/// The environment part is kept between frames (`LitScene`): after each
/// lighting change — the sky tipped over, the medium thickened, only a
/// point light moved — a frame of the kept method equals that of a method
/// prepared afresh on the changed scene.
#[test]
fn kept_lighting_follows_every_lighting_change() {
    let mut s = scene(sky(1.0), fog(0.08, 0.7, 12.0));
    let mut kept = FogRelighter::new(FogOptions::default()).unwrap();
    let first = render(&mut kept, &s, 1);
    let frame = |m: &mut FogRelighter, s: &Scene| {
        m.render(s, &FrameRequest::new(s.camera), &NoProgress)
            .unwrap()
            .image
    };
    let changes: [&dyn Fn(&mut Scene); 3] = [
        &|s| s.world_from_env = glam::Mat3::from_rotation_x(1.1),
        &|s| s.medium = fog(0.2, 0.7, 12.0),
        &|s| s.point_lights[0].position = Vec3::new(1.0, 2.5, -1.0),
    ];
    for (i, change) in changes.iter().enumerate() {
        change(&mut s);
        kept.set_lighting(&s, &NoProgress).unwrap();
        let got = frame(&mut kept, &s);
        let want = render(
            &mut FogRelighter::new(FogOptions::default()).unwrap(),
            &s,
            1,
        );
        let e = max_rel_diff(&got, &want);
        assert!(e < 1e-6, "change {i}: kept vs fresh method differ by {e}");
        assert!(
            max_rel_diff(&got, &first) > 1e-3,
            "change {i} changed nothing in the image"
        );
    }
}

/// The environment's mean radiance (the view segment's in-scattered
/// light) is kept between lighting changes only while the environment is
/// the same map: after a turn (kept) and then a brighter sky (a lighting
/// change too) the kept method's frame is a fresh method's, not the old
/// sky's.
#[test]
fn kept_environment_mean_follows_a_new_environment() {
    let mut s = scene(sky(1.0), fog(0.08, 0.7, 12.0));
    let mut kept = FogRelighter::new(FogOptions::default()).unwrap();
    let first = render(&mut kept, &s, 1);
    s.world_from_env = glam::Mat3::from_rotation_y(0.7);
    kept.set_lighting(&s, &NoProgress).unwrap();
    s.env = sky(2.0);
    kept.set_lighting(&s, &NoProgress).unwrap();
    let got = kept
        .render(&s, &FrameRequest::new(s.camera), &NoProgress)
        .unwrap()
        .image;
    let want = render(
        &mut FogRelighter::new(FogOptions::default()).unwrap(),
        &s,
        1,
    );
    let e = max_rel_diff(&got, &want);
    assert!(e < 1e-6, "kept vs fresh method differ by {e}");
    assert!(max_rel_diff(&got, &first) > 1e-3);
}

/// A uniform sky L in fog, a Lambert sphere of albedo ρ alone: the sky seen
/// through the fog along a chord of thickness T_d is L (e^{−T_d} + a w₀ g)
/// (w₀ the ball kernel's band-0 weight, g the chord's glow weight), and a
/// sphere pixel at view distance D is e^{−βD} k ρ L (e^{−T} + a w₀) +
/// s a L G_c (eqs. 3.35–3.37 with the ball's kernel, k the point's factor
/// for its place in the ball, then the view segment with its share s of
/// scattering).
#[test]
fn uniform_sky_in_fog_matches_the_closed_form() {
    let (beta, albedo, radius, rho, l) = (0.1f32, 0.8f32, 10.0f32, 0.7f32, 2.0f32);
    let env = EnvMap::from_fn(
        Param::LatLong {
            width: 32,
            height: 16,
        },
        |_| Vec3::splat(l),
    );
    let sphere = relight_geom::shapes::uv_sphere_at(Vec3::ZERO, 1.0, 64, 32);
    let mut cam = camera(21, 21);
    cam.eye = Vec3::new(0.0, 0.0, 4.0);
    cam.target = Vec3::ZERO;
    let mut s = Scene::new(vec![Object::new(Arc::new(sphere), lambert(rho))], env, cam);
    s.medium = fog(beta, albedo, radius);
    let mut m = FogRelighter::new(FogOptions::default()).unwrap();
    let img = render(&mut m, &s, 1);
    let t = f64::from(beta * radius);
    let w0 = relight_fog::psf::ball_convolution_weights(t, 1)[0] as f32;
    let lit = l * ((-t as f32).exp() + albedo * w0);
    let (o, d) = s.camera.ray(0.5, 0.5);
    let chords = relight_fog::view_segment::ChordGlow::new(&s.medium.unwrap());
    let [direct, glow] = chords.weights(o, d);
    let (_, t_out) = s.medium.unwrap().ball_span(o, d).unwrap();
    assert!((direct - (-beta * t_out).exp()).abs() < 1e-6);
    let sky = l * (direct + albedo * w0 * glow);
    let sky_px = img.pixels[0].x;
    assert!(
        (sky_px - sky).abs() < 1e-3 * sky,
        "foggy sky {sky_px} vs L(e^-T_d + a w0 g) = {sky}"
    );
    // Centre pixel: the sphere's front at distance 3, its view segment's
    // share s of a uniform sky's scattering (`ChordGlow::segment`, exact
    // for one; close to the centre's (1 − e^{−βD}) e^{−T} / G_c there).
    let f = (-beta * 3.0f32).exp();
    let [seg_f, share] = chords.segment(cam.eye, Vec3::NEG_Z, 3.0);
    assert!((seg_f - f).abs() < 1e-6);
    let centres = (1.0 - f) * (-t as f32).exp() / chords.centre();
    assert!(
        (share - centres).abs() < 0.05 * centres,
        "{share} vs {centres}"
    );
    // The front point (0, 0, 1) facing the eye: lit for its place in the
    // ball (`BallIrradiance`, a few % above the centre's light).
    let k = relight_fog::ball_light::BallIrradiance::new(&s.medium.unwrap(), &chords)
        .factor(Vec3::Z, Vec3::Z);
    assert!(k > 1.0 && k < 1.1, "{k}");
    let want = f * rho * lit * k + share * albedo * l * chords.centre();
    let got = img.pixels[10 * 21 + 10].x;
    assert!(
        (got - want).abs() < 1e-3 * want,
        "sphere centre {got} vs closed form {want}"
    );
}

/// An empty pixel's airlight runs to the fog ball's edge: eq. 3.5 integrated
/// numerically over that finite segment, times the albedo.
#[test]
fn empty_pixels_integrate_the_airlight_to_the_ball_edge() {
    let (beta, albedo, radius) = (0.15f32, 0.6f32, 6.0f32);
    let mut s = scene(black(), fog(beta, albedo, radius));
    s.objects.truncate(1); // the floor only: the upper rows are empty
    s.point_lights.truncate(1);
    let mut m = FogRelighter::new(FogOptions::default()).unwrap();
    let img = render(&mut m, &s, 1);
    let light = s.point_lights[0];
    let medium = s.medium.unwrap();
    for (x, y) in [(3usize, 1usize), (20, 2), (36, 4), (8, 6)] {
        let (o, d) = s.camera.ray(x as f32 + 0.5, y as f32 + 0.5);
        let (_, t_exit) = medium.ball_span(o, d).unwrap();
        let to = light.position - o;
        let gamma = f64::from((to.normalize().dot(d)).clamp(-1.0, 1.0)).acos();
        let want = f64::from(albedo)
            * airlight_eq35(
                f64::from(beta),
                f64::from(light.intensity.x),
                f64::from(to.length()),
                f64::from(t_exit),
                gamma,
            );
        let got = f64::from(img.pixels[y * 40 + x].x);
        assert!(
            ((got - want) / want).abs() < 0.01,
            "pixel ({x}, {y}): {got} vs eq. 3.5 to the ball edge {want}"
        );
    }
}

/// From an eye outside the fog ball the medium starts at each ray's entry
/// (`relight_fog::view_segment`): an empty pixel is eq. 3.5 integrated
/// from the entry point to the exit, an independent check of the
/// renderer's e^{β t_in} (M − A(t_in)); a ray that misses the ball is black.
#[test]
fn from_outside_the_ball_empty_pixels_integrate_from_the_entry() {
    let (beta, albedo, radius) = (0.15f32, 0.6f32, 6.0f32);
    let mut s = scene(black(), fog(beta, albedo, radius));
    s.objects.truncate(1);
    s.point_lights.truncate(1);
    s.camera.eye = Vec3::new(0.0, 2.5, 10.0);
    s.camera.vfov_deg = 60.0;
    let mut m = FogRelighter::new(FogOptions::default()).unwrap();
    let img = render(&mut m, &s, 1);
    let light = s.point_lights[0];
    let medium = s.medium.unwrap();
    let (mut through, mut missed) = (0, 0);
    for y in (0..24).step_by(3) {
        for x in (0..40).step_by(3) {
            let (o, d) = s.camera.ray(x as f32 + 0.5, y as f32 + 0.5);
            let got = f64::from(img.pixels[y * 40 + x].x);
            let Some((t_in, t_out)) = medium.ball_span(o, d) else {
                assert_eq!(got, 0.0, "pixel ({x}, {y}) misses the ball");
                missed += 1;
                continue;
            };
            // The floor's pixels are not empty.
            if d.y < 0.0 && -(o.y / d.y) < t_out {
                continue;
            }
            assert!(t_in > 0.0, "the eye is outside");
            let p = o + t_in * d;
            let to = light.position - p;
            let gamma = f64::from((to.normalize().dot(d)).clamp(-1.0, 1.0)).acos();
            let want = f64::from(albedo)
                * airlight_eq35(
                    f64::from(beta),
                    f64::from(light.intensity.x),
                    f64::from(to.length()),
                    f64::from(t_out - t_in),
                    gamma,
                );
            assert!(
                ((got - want) / want).abs() < 0.01,
                "pixel ({x}, {y}): {got} vs eq. 3.5 from the entry {want}"
            );
            through += 1;
        }
    }
    assert!(
        through > 20 && missed > 5,
        "{through} through, {missed} missed"
    );
}

/// A camera moved along its central ray from outside the ball to just
/// inside it sees the same central pixel: the model from the ball's edge
/// equals the model from an eye there, on an object (the sphere) and on an
/// empty ray across the ball, with an environment (the chord's direct and
/// scattered parts, the view segment from the entry) and without.
#[test]
fn an_eye_outside_the_ball_sees_what_an_eye_at_its_edge_sees() {
    let (beta, albedo, radius) = (0.15f32, 0.7f32, 6.0f32);
    for env in [black(), sky(1.0)] {
        for target in [Vec3::new(0.0, 0.5, 0.0), Vec3::new(0.3, 4.0, 0.0)] {
            let mut s = scene(env.clone(), fog(beta, albedo, radius));
            let far = Vec3::new(1.0, 2.0, 15.0);
            s.camera = Camera {
                eye: far,
                target,
                width: 41,
                height: 25,
                ..s.camera
            };
            let centre = 12 * 41 + 20;
            let mut m = FogRelighter::new(FogOptions::default()).unwrap();
            let outside = render(&mut m, &s, 1).pixels[centre];
            let d = (target - far).normalize();
            let (t_in, _) = s.medium.unwrap().ball_span(far, d).unwrap();
            s.camera.eye = far + (t_in + 1e-3) * d;
            assert!(s.camera.eye.length() < radius);
            let inside = render(&mut m, &s, 1).pixels[centre];
            let e = (outside - inside).abs().max_element() / inside.max_element();
            assert!(
                e < 2e-3,
                "target {target}, sky {}: outside {outside} vs at the edge {inside}",
                env.texels[0].x > 0.0
            );
        }
    }
}

/// Every empty pixel inside a fog ball (shaded by the batch loop as the
/// airlight to a black surface at the ball's edge) equals the scalar
/// `FogModel::airlight` to that point, summed over the lights.
#[test]
fn batched_ball_edge_airlight_equals_the_scalar_airlight() {
    let (beta, albedo, radius) = (0.15f32, 0.6f32, 6.0f32);
    let mut s = scene(black(), fog(beta, albedo, radius));
    s.objects.truncate(1);
    let objects = scene_objects(&s);
    let tables = FogTables::build_for(64, objects.iter().map(|o| &o.material)).unwrap();
    let mut settings = FogSettings::new(&tables, beta);
    settings.albedo = albedo;
    settings.ball_radius = Some(radius);
    let lights: Vec<relight_fog::PointLight> = s
        .point_lights
        .iter()
        .map(|l| relight_fog::PointLight::new(l.position, l.intensity))
        .collect();
    let img = render_fog(&objects, &s.camera, &lights, &settings).unwrap();
    let model = relight_fog::FogModel::new(&tables, beta, &settings.phase, settings.interp)
        .unwrap()
        .with_albedo(albedo)
        .unwrap();
    let prepared = model.prepare_lights(s.camera.eye, &lights).unwrap();
    let rays = s.camera.ray_frame();
    let eye = s.camera.eye;
    let mut r = relight_render::raster::Rasterizer::new();
    relight_fog::render::rasterize_objects(&mut r, &objects, &[], &s.camera).unwrap();
    let mut empty = 0;
    for y in 0..s.camera.height {
        for x in 0..s.camera.width {
            if r.gbuffer().triangle[y * s.camera.width + x] != relight_render::raster::NO_TRIANGLE {
                continue;
            }
            empty += 1;
            let d = rays.dir(x as f32 + 0.5, y as f32 + 0.5);
            let b = eye.dot(d);
            let t = -b
                + (b * b - (eye.length_squared() - radius * radius))
                    .max(0.0)
                    .sqrt();
            let hit = Some((eye + t * d, t, (-beta * t).exp()));
            let want: Vec3 = prepared
                .iter()
                .map(|l| l.intensity * model.airlight(l, d, hit))
                .sum();
            let got = img.pixels[y * s.camera.width + x];
            let e = (got - want).abs().max_element() / want.max_element().max(1e-12);
            assert!(e < 2e-3, "pixel ({x}, {y}): batch {got} vs scalar {want}");
        }
    }
    assert!(empty > 100, "{empty} empty pixels");
}

#[test]
fn unsupported_features_are_check_scene_errors() {
    let m = FogRelighter::new(FogOptions::default()).unwrap();
    let base = scene(black(), fog(0.05, 1.0, 10.0));
    assert!(check_scene(&m, &base, false).unwrap().is_empty());
    let mut shadows = base.clone();
    shadows.visibility = true;
    let mut area = base.clone();
    area.area_lights.push(AreaLight {
        center: Vec3::new(0.0, 2.0, 0.0),
        size: Vec2::ONE,
        world_from_light: glam::Mat3::from_cols(Vec3::X, Vec3::Z, -Vec3::Y),
        intensity: Vec3::ONE,
        texture: None,
        light_field: None,
    });
    for (s, feature) in [
        (shadows, SceneFeature::Visibility),
        (area, SceneFeature::AreaLights),
    ] {
        match check_scene(&m, &s, true) {
            Err(MethodError::Unsupported {
                method: "fog",
                feature: f,
                approximate: None,
            }) => assert_eq!(f, feature),
            other => panic!("{feature}: expected Unsupported, got {other:?}"),
        }
    }
    // The environment in fog is the thesis' own model (§3.6.4): rendered,
    // with its approximations stated, not refused.
    let lit = scene(sky(1.0), fog(0.05, 1.0, 10.0));
    assert!(check_scene(&m, &lit, false).unwrap().is_empty());
    assert!(ENVIRONMENT_APPROXIMATION.contains("3.35"));
}

#[test]
fn bad_media_and_lights_outside_the_ball_are_errors() {
    let mut m = FogRelighter::new(FogOptions::default()).unwrap();
    let small = scene(black(), fog(0.05, 1.0, 2.5));
    let e = m.prepare(&small, &NoProgress).unwrap_err().to_string();
    assert!(e.contains("point light 1") && e.contains("fog ball"), "{e}");
    // An eye 40 mean free paths out: the model's terms would leave f32.
    let mut distant = scene(black(), fog(0.5, 1.0, 4.0));
    distant.camera.eye = Vec3::new(0.0, 1.0, 90.0);
    m.prepare(&distant, &NoProgress).unwrap();
    let e = m
        .render(&distant, &FrameRequest::new(distant.camera), &NoProgress)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("mean free paths") && e.contains("fog ball"),
        "{e}"
    );
    for (medium, what) in [
        (fog(-1.0, 1.0, 10.0), "medium.beta"),
        (fog(0.1, 1.5, 10.0), "medium.albedo"),
        (fog(0.1, 1.0, 0.0), "medium.radius"),
    ] {
        let e = m
            .prepare(&scene(black(), medium), &NoProgress)
            .unwrap_err()
            .to_string();
        assert!(e.contains(what), "{what}: {e}");
    }
    for opts in [
        FogOptions {
            table_size: 1,
            ..FogOptions::default()
        },
        FogOptions {
            env_order: 0,
            ..FogOptions::default()
        },
    ] {
        assert!(FogRelighter::new(opts).is_err(), "{opts:?}");
    }
}
