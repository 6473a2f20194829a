//! The rasterizer's tests: coverage against analytic areas, the fill rule on
//! shared edges, perspective-correct barycentrics against ray casting, near-plane
//! clipping, the z-test, culling, determinism across strips and threads, and
//! typed errors for bad input.

use super::*;

/// Camera at z = 1 looking down −Z with a 90° field of view: the plane
/// z = 0 maps world x ∈ [−1, 1] onto the image width (square images).
fn flat_camera(size: usize) -> Camera {
    Camera {
        eye: Vec3::new(0.0, 0.0, 1.0),
        target: Vec3::ZERO,
        up: Vec3::Y,
        vfov_deg: 90.0,
        width: size,
        height: size,
        image_offset: glam::Vec2::ZERO,
    }
}

/// World point on z = 0 at image coordinates (px, py) of `flat_camera(size)`.
fn at_pixel(size: usize, px: f32, py: f32) -> Vec3 {
    let s = size as f32;
    Vec3::new(2.0 * px / s - 1.0, 1.0 - 2.0 * py / s, 0.0)
}

/// Deterministic uniform numbers in [0, 1).
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f32 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
}

fn options() -> RasterOptions {
    RasterOptions {
        near: 0.01,
        far: 100.0,
        ..Default::default()
    }
}

/// Hits per pixel when each triangle is rasterized on its own.
fn hit_counts(camera: &Camera, positions: &[Vec3], triangles: &[[u32; 3]]) -> Vec<u32> {
    let mut r = Rasterizer::new();
    let mut hits = vec![0u32; camera.width * camera.height];
    for t in triangles {
        let tri = [*t];
        r.rasterize(camera, &[DrawCall::new(positions, &tri)], &options())
            .unwrap();
        for (h, &id) in hits.iter_mut().zip(&r.gbuffer().triangle) {
            *h += u32::from(id != NO_TRIANGLE);
        }
    }
    hits
}

#[test]
fn single_triangle_coverage_matches_analytic_area() {
    let size = 128;
    let cam = flat_camera(size);
    let mut rng = Lcg(7);
    for _ in 0..20 {
        let p: Vec<[f32; 2]> = (0..3)
            .map(|_| [8.0 + 112.0 * rng.next(), 8.0 + 112.0 * rng.next()])
            .collect();
        let positions: Vec<Vec3> = p.iter().map(|q| at_pixel(size, q[0], q[1])).collect();
        let area = 0.5
            * ((p[1][0] - p[0][0]) * (p[2][1] - p[0][1])
                - (p[2][0] - p[0][0]) * (p[1][1] - p[0][1]))
                .abs();
        let perimeter: f32 = (0..3)
            .map(|i| (glam::Vec2::from(p[i]) - glam::Vec2::from(p[(i + 1) % 3])).length())
            .sum();
        let mut r = Rasterizer::new();
        r.rasterize(&cam, &[DrawCall::new(&positions, &[[0, 1, 2]])], &options())
            .unwrap();
        let covered = r.gbuffer().covered_pixels() as f32;
        // Pixels whose centre lies within half a pixel diagonal of an edge can go either way.
        assert!(
            (covered - area).abs() <= 0.75 * perimeter + 1.0,
            "covered {covered} px, analytic area {area} px², perimeter {perimeter}"
        );
    }
}

#[test]
fn shared_edges_cover_every_pixel_exactly_once() {
    let size = 64;
    let cam = flat_camera(size);
    // A fan around a pixel centre with its rim on pixel centres and
    // pixel corners: many centres lie exactly on the shared edges.
    let c = at_pixel(size, 32.5, 32.5);
    let rim = [
        (8.5, 8.5),
        (32.5, 8.0),
        (56.5, 8.5),
        (56.0, 32.5),
        (56.5, 56.5),
        (32.5, 56.0),
        (8.5, 56.5),
        (8.0, 32.5),
    ];
    let mut positions = vec![c];
    positions.extend(rim.iter().map(|&(x, y)| at_pixel(size, x, y)));
    let triangles: Vec<[u32; 3]> = (0..8)
        .map(|i| [0, 1 + i as u32, 1 + ((i + 1) % 8) as u32])
        .collect();
    let hits = hit_counts(&cam, &positions, &triangles);
    // Every pixel centre strictly inside the octagon is hit exactly once.
    for y in 10..55 {
        for x in 10..55 {
            assert_eq!(
                hits[y * size + x],
                1,
                "pixel ({x}, {y}) hit {} times",
                hits[y * size + x]
            );
        }
    }
    assert!(hits.iter().all(|&h| h <= 1), "a pixel was hit twice");

    // A jittered grid of quads split along random diagonals.
    let n = 8;
    let mut rng = Lcg(3);
    let mut positions = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let border = i == 0 || j == 0 || i == n || j == n;
            let (jx, jy) = if border {
                (0.0, 0.0)
            } else {
                (rng.next() * 4.0 - 2.0, rng.next() * 4.0 - 2.0)
            };
            // Snap to 1/16 px so vertices often sit on pixel centres' rows/columns.
            let q = |v: f32| (v * 16.0).round() / 16.0;
            positions.push(at_pixel(
                size,
                q(4.0 + 7.0 * i as f32 + jx),
                q(4.0 + 7.0 * j as f32 + jy),
            ));
        }
    }
    let mut triangles = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let v = |a: usize, b: usize| (b * (n + 1) + a) as u32;
            let (a, b, c, d) = (v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j + 1));
            if rng.next() < 0.5 {
                triangles.extend([[a, b, c], [a, c, d]]);
            } else {
                triangles.extend([[a, b, d], [b, c, d]]);
            }
        }
    }
    let hits = hit_counts(&cam, &positions, &triangles);
    for y in 4..60 {
        for x in 4..60 {
            assert_eq!(
                hits[y * size + x],
                1,
                "grid: pixel ({x}, {y}) hit {} times",
                hits[y * size + x]
            );
        }
    }
}

/// A slanted quad in perspective: interpolated attributes (world x, y, z
/// and a checker parameter) equal the analytic ray–plane intersection.
#[test]
fn perspective_correct_interpolation_matches_ray_cast() {
    let cam = Camera {
        eye: Vec3::new(0.3, 1.0, 3.0),
        target: Vec3::new(0.0, 0.0, -2.0),
        up: Vec3::Y,
        vfov_deg: 60.0,
        width: 160,
        height: 120,
        image_offset: glam::Vec2::ZERO,
    };
    // Floor quad y = 0, x ∈ [−2, 2], z ∈ [−10, 1]: strongly foreshortened.
    let positions = [
        Vec3::new(-2.0, 0.0, 1.0),
        Vec3::new(2.0, 0.0, 1.0),
        Vec3::new(2.0, 0.0, -10.0),
        Vec3::new(-2.0, 0.0, -10.0),
    ];
    let triangles = [[0u32, 1, 2], [0, 2, 3]];
    let attrs: Vec<f32> = positions.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
    let draws = [DrawCall::new(&positions, &triangles)
        .with_attributes(3, &attrs)
        .with_object_id(9)];
    let mut r = Rasterizer::new();
    let mut img = Image::new(1, 1);
    let worst = std::sync::Mutex::new(0.0f32);
    r.render(
        &cam,
        &draws,
        |f| {
            let (o, d) = cam.ray(f.x as f32 + 0.5, f.y as f32 + 0.5);
            let t = -o.y / d.y;
            let hit = o + d * t;
            let interp = Vec3::from_slice(f.attributes);
            let err = (interp - hit).length().max((f.position - hit).length()) / (hit - o).length();
            let mut w = worst.lock().unwrap();
            *w = w.max(err);
            assert_eq!(f.object, 9);
            // Checker of period 1 in x and z.
            let checker = ((interp.x.floor() + interp.z.floor()) as i32 & 1) as f32;
            Vec3::new(checker, f.normal.y, 0.0)
        },
        Background::Color(Vec3::splat(-1.0)),
        &options(),
        &mut img,
    )
    .unwrap();
    let covered = r.gbuffer().covered_pixels();
    assert!(covered > 3000, "floor covers only {covered} pixels");
    let worst = *worst.lock().unwrap();
    // One pixel subtends 60°/120 ≈ 8.7e-3 rad: 5e-4 is 6 % of a pixel (affine
    // interpolation is off by up to 10 % of the distance here).
    assert!(worst < 5e-4, "worst relative position error {worst}");
    // Checker agrees with the ray-cast checker except right on its lines.
    let mut wrong = 0;
    for y in 0..cam.height {
        for x in 0..cam.width {
            let (o, d) = cam.ray(x as f32 + 0.5, y as f32 + 0.5);
            let t = -o.y / d.y;
            let hit = o + d * t;
            let inside = t > 0.0 && hit.x.abs() < 2.0 && hit.z < 1.0 && hit.z > -10.0;
            let px = img.get(x, y);
            if inside && r.gbuffer().is_covered(y * cam.width + x) {
                let checker = ((hit.x.floor() + hit.z.floor()) as i32 & 1) as f32;
                wrong += usize::from(px.x != checker);
                assert!((px.y - 1.0).abs() < 1e-6, "floor normal {px}");
            }
        }
    }
    assert!(
        wrong < covered / 200,
        "{wrong} of {covered} checker pixels disagree with the ray cast"
    );
}

/// Möller–Trumbore ray–triangle hit distance.
fn ray_triangle(o: Vec3, d: Vec3, p: [Vec3; 3]) -> Option<f32> {
    let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
    let h = d.cross(e2);
    let a = e1.dot(h);
    if a.abs() < 1e-12 {
        return None;
    }
    let s = o - p[0];
    let u = s.dot(h) / a;
    let q = s.cross(e1);
    let v = d.dot(q) / a;
    let t = e2.dot(q) / a;
    (u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t > 0.0).then_some(t)
}

#[test]
fn near_plane_clipping_gives_correct_coverage_and_no_nans() {
    let cam = Camera {
        eye: Vec3::new(0.0, 1.0, 0.0),
        target: Vec3::new(0.0, 0.2, -1.0),
        up: Vec3::Y,
        vfov_deg: 70.0,
        width: 200,
        height: 150,
        image_offset: glam::Vec2::ZERO,
    };
    // A large floor triangle reaching behind the camera, and a wall
    // triangle that crosses the camera plane beside the eye.
    let positions = [
        Vec3::new(-50.0, 0.0, 20.0),
        Vec3::new(50.0, 0.0, 20.0),
        Vec3::new(0.0, 0.0, -60.0),
        Vec3::new(0.5, -1.0, 5.0),
        Vec3::new(0.5, 3.0, 5.0),
        Vec3::new(0.5, 1.0, -8.0),
    ];
    let triangles = [[0u32, 1, 2], [3, 4, 5]];
    let colors = [Vec3::ONE; 6];
    let draws = [DrawCall::new(&positions, &triangles)];
    let mut r = Rasterizer::new();
    let mut img = Image::new(1, 1);
    let stats = r
        .render_gouraud(
            &cam,
            &draws,
            &[&colors],
            Background::Color(Vec3::ZERO),
            &options(),
            &mut img,
        )
        .unwrap();
    assert_eq!(stats.clipped, 2, "both triangles cross the near plane");
    assert!(
        img.pixels.iter().all(|p| p.is_finite()),
        "NaN or Inf in the image"
    );
    let mut mismatches = 0;
    let mut wrong_triangle = 0;
    for y in 0..cam.height {
        for x in 0..cam.width {
            let (o, d) = cam.ray(x as f32 + 0.5, y as f32 + 0.5);
            let hits: Vec<(f32, u32)> = triangles
                .iter()
                .enumerate()
                .filter_map(|(i, t)| {
                    ray_triangle(o, d, t.map(|k| positions[k as usize])).map(|h| (h, i as u32))
                })
                .collect();
            let nearest = hits.iter().copied().min_by(|a, b| a.0.total_cmp(&b.0));
            let id = r.gbuffer().triangle[y * cam.width + x];
            match nearest {
                None => mismatches += usize::from(id != NO_TRIANGLE),
                Some((_, t)) => {
                    mismatches += usize::from(id == NO_TRIANGLE);
                    wrong_triangle += usize::from(id != NO_TRIANGLE && id != t);
                }
            }
        }
    }
    let covered = r.gbuffer().covered_pixels();
    assert!(covered > 10_000, "covered {covered}");
    // Only pixels whose centres graze an edge may differ.
    assert!(
        mismatches <= cam.width + cam.height,
        "{mismatches} coverage mismatches against the ray cast"
    );
    assert!(
        wrong_triangle <= cam.height,
        "{wrong_triangle} pixels show the farther triangle"
    );
    // Barycentrics of clipped triangles stay in the triangle and agree
    // with 2D homogeneous rasterization of the unclipped triangle.
    let ctx = r.resolve_context();
    for (i, l) in r.barycentric_buffer(&draws).into_iter().enumerate() {
        assert!(
            l.is_finite() && l.min_element() > -1e-3 && (l.element_sum() - 1.0).abs() < 1e-4,
            "barycentrics {l}"
        );
        let id = r.gbuffer().triangle[i];
        if id != NO_TRIANGLE {
            let u = triangles[id as usize].map(|k| r.clip[k as usize]);
            let h = homogeneous_barycentrics(ctx.ndc(i % cam.width, i / cam.width), u);
            assert!(
                (h - l).abs().max_element() < 2e-3,
                "pixel {i}: rasterized {l} vs homogeneous {h}"
            );
        }
    }
}

#[test]
fn z_buffer_keeps_the_nearest_triangle_in_any_order() {
    let size = 64;
    let cam = flat_camera(size);
    let near = [
        at_pixel(size, 10.0, 10.0) + Vec3::Z * 0.2,
        at_pixel(size, 50.0, 12.0) + Vec3::Z * 0.2,
        at_pixel(size, 20.0, 50.0) + Vec3::Z * 0.2,
    ];
    let far = [
        at_pixel(size, 5.0, 30.0),
        at_pixel(size, 60.0, 5.0),
        at_pixel(size, 60.0, 60.0),
    ];
    for order in [0u32, 1] {
        let positions: Vec<Vec3> = if order == 0 {
            near.iter().chain(&far).copied().collect()
        } else {
            far.iter().chain(&near).copied().collect()
        };
        let tris = [[0u32, 1, 2], [3, 4, 5]];
        let mut r = Rasterizer::new();
        r.rasterize(&cam, &[DrawCall::new(&positions, &tris)], &options())
            .unwrap();
        let near_id = order; // index of the near triangle
        // A pixel inside both: (30, 25).
        let i = 25 * size + 30;
        assert_eq!(r.gbuffer().triangle[i], near_id, "order {order}");
        // Depths: the near triangle is closer to the camera.
        let mut r_far = Rasterizer::new();
        let only_far = [tris[1 - order as usize]];
        r_far
            .rasterize(&cam, &[DrawCall::new(&positions, &only_far)], &options())
            .unwrap();
        assert!(r.gbuffer().depth[i] < r_far.gbuffer().depth[i]);
    }
}

#[test]
fn culling_follows_counter_clockwise_front_faces() {
    let size = 32;
    let cam = flat_camera(size);
    // Counter-clockwise as seen from the camera (+Z looking down −Z).
    let positions = [
        Vec3::new(-0.5, -0.5, 0.0),
        Vec3::new(0.5, -0.5, 0.0),
        Vec3::new(0.0, 0.5, 0.0),
    ];
    let ccw = [[0u32, 1, 2]];
    let cw = [[0u32, 2, 1]];
    let mut r = Rasterizer::new();
    let back = options().cull_back();
    let front = RasterOptions {
        cull: CullMode::Front,
        ..options()
    };
    assert_eq!(
        r.rasterize(&cam, &[DrawCall::new(&positions, &ccw)], &back)
            .unwrap()
            .binned,
        1
    );
    assert!(r.gbuffer().covered_pixels() > 100);
    assert_eq!(
        r.rasterize(&cam, &[DrawCall::new(&positions, &cw)], &back)
            .unwrap()
            .binned,
        0
    );
    assert_eq!(r.gbuffer().covered_pixels(), 0);
    assert_eq!(
        r.rasterize(&cam, &[DrawCall::new(&positions, &ccw)], &front)
            .unwrap()
            .binned,
        0
    );
    // The geometric normal of a front face points to the eye.
    let mut img = Image::new(1, 1);
    r.render(
        &cam,
        &[DrawCall::new(&positions, &ccw)],
        |f| f.normal,
        Background::Color(Vec3::ZERO),
        &back,
        &mut img,
    )
    .unwrap();
    assert_eq!(img.get(16, 16), Vec3::Z);
}

/// A draw's own culling mode overrides the frame's, for that draw only.
#[test]
fn per_draw_culling_overrides_the_options() {
    let cam = flat_camera(32);
    let positions = [
        Vec3::new(-0.5, -0.5, 0.0),
        Vec3::new(0.5, -0.5, 0.0),
        Vec3::new(0.0, 0.5, 0.0),
    ];
    let cw = [[0u32, 2, 1]];
    let mut r = Rasterizer::new();
    let binned = |r: &mut Rasterizer, draws: &[DrawCall], o: &RasterOptions| {
        r.rasterize(&cam, draws, o).unwrap().binned
    };
    let culled = DrawCall::new(&positions, &cw).with_cull(CullMode::Back);
    let kept = DrawCall::new(&positions, &cw).with_cull(CullMode::None);
    assert_eq!(binned(&mut r, &[culled], &options()), 0);
    assert_eq!(binned(&mut r, &[kept], &options().cull_back()), 1);
    assert!(r.gbuffer().covered_pixels() > 100);
    // Two draws in one frame: only the one asking for culling loses it.
    let plain = DrawCall::new(&positions, &cw);
    assert_eq!(binned(&mut r, &[plain, culled], &options()), 1);
}

/// A 173 × 97 view of `torus_grid` from above and in front.
fn torus_camera() -> Camera {
    Camera {
        eye: Vec3::new(0.4, 1.2, 1.6),
        target: Vec3::ZERO,
        up: Vec3::Y,
        vfov_deg: 60.0,
        width: 173,
        height: 97,
        image_offset: glam::Vec2::ZERO,
    }
}

#[test]
fn strips_and_threads_do_not_change_the_result() {
    let (positions, triangles, uv) = torus_grid(60, 24);
    let draws = [
        DrawCall::new(&positions, &triangles).with_attributes(2, &uv),
        DrawCall::new(&positions[..300], &triangles[..200]).with_object_id(1),
    ];
    let cam = torus_camera();
    let mut single = Rasterizer::new();
    let whole = RasterOptions {
        strip_height: cam.height,
        ..options()
    };
    single.rasterize(&cam, &draws, &whole).unwrap();
    for strip_height in [1, 7, 32] {
        let mut r = Rasterizer::new();
        r.rasterize(
            &cam,
            &draws,
            &RasterOptions {
                strip_height,
                ..options()
            },
        )
        .unwrap();
        assert_eq!(
            r.gbuffer().triangle,
            single.gbuffer().triangle,
            "strip height {strip_height}"
        );
        assert_eq!(
            r.gbuffer().depth,
            single.gbuffer().depth,
            "strip height {strip_height}"
        );
    }
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let mut r = Rasterizer::new();
    pool.install(|| r.rasterize(&cam, &draws, &options()).unwrap());
    assert_eq!(
        r.gbuffer().triangle,
        single.gbuffer().triangle,
        "one thread"
    );
    assert!(single.gbuffer().covered_pixels() > 2000);
    // Reusing the rasterizer for another frame gives the same answer.
    r.rasterize(&cam, &draws, &whole).unwrap();
    r.rasterize(&cam, &draws, &options()).unwrap();
    assert_eq!(
        r.gbuffer().triangle,
        single.gbuffer().triangle,
        "reused buffers"
    );
}

/// The AVX2 + FMA copy of the strip raster (taken by `rasterize` where
/// the CPU has both) writes what the portable copy writes, bit for bit:
/// every strip of a frame (with a near-clipped draw, so that clipped pieces
/// are drawn too) is drawn again by `Strip::draw_bins` and compared.
#[test]
fn avx2_strip_raster_matches_the_portable_copy() {
    if !relight_isa::avx2() {
        assert!(
            std::env::var_os("CI").is_none(),
            "CI: no AVX2 + FMA on this CPU, so the fast copy is not tested"
        );
    }
    let (positions, triangles, _) = torus_grid(60, 24);
    // A floor reaching behind the eye: clipped against the near plane.
    let floor = [
        Vec3::new(-50.0, -0.5, 20.0),
        Vec3::new(50.0, -0.5, 20.0),
        Vec3::new(0.0, -0.5, -60.0),
    ];
    let draws = [
        DrawCall::new(&positions, &triangles),
        DrawCall::new(&floor, &[[0, 1, 2]]).with_object_id(1),
    ];
    let cam = torus_camera();
    let opts = RasterOptions {
        strip_height: 16,
        ..options()
    };
    let mut r = Rasterizer::new();
    let stats = r.rasterize(&cam, &draws, &opts).unwrap();
    assert!(stats.clipped > 0, "no clipped triangle: {stats:?}");
    let (w, h) = (cam.width, cam.height);
    let (mut depth, mut ids, mut bary) = (
        vec![EMPTY_DEPTH; w * h],
        vec![NO_TRIANGLE; w * h],
        vec![[0.0f32; 2]; w * h],
    );
    let rows = opts.strip_height * w;
    for (s, ((depth, ids), bary)) in depth
        .chunks_mut(rows)
        .zip(ids.chunks_mut(rows))
        .zip(bary.chunks_mut(rows))
        .enumerate()
    {
        let y0 = (s * opts.strip_height) as i64;
        let mut strip = Strip {
            y1: y0 + (depth.len() / w) as i64,
            depth,
            ids,
            bary,
            width: w as i64,
            y0,
        };
        strip.draw_bins(&r.chunks, &r.triangle_offsets, s);
    }
    let g = r.gbuffer();
    assert!(g.covered_pixels() > 2000);
    assert_eq!(ids, g.triangle);
    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&depth), bits(&g.depth));
    assert_eq!(
        bits(bary.as_flattened()),
        bits(g.barycentrics.as_flattened())
    );
}

/// A torus coloured by position (per-vertex colours, and the same as a
/// 3-float attribute), seen from above at 96 × 64: the shading passes'
/// comparisons.
struct ColouredTorus {
    positions: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
    colors: Vec<Vec3>,
    attrs: Vec<f32>,
    cam: Camera,
}

/// [`ColouredTorus`]'s data.
fn coloured_torus() -> ColouredTorus {
    let (positions, triangles, _) = torus_grid(40, 16);
    let colors: Vec<Vec3> = positions
        .iter()
        .map(|p| *p * 0.5 + Vec3::splat(0.5))
        .collect();
    let attrs: Vec<f32> = colors.iter().flat_map(|c| c.to_array()).collect();
    let cam = Camera {
        eye: Vec3::new(0.0, 1.0, 2.5),
        target: Vec3::ZERO,
        up: Vec3::Y,
        vfov_deg: 50.0,
        width: 96,
        height: 64,
        image_offset: glam::Vec2::ZERO,
    };
    ColouredTorus {
        positions,
        triangles,
        colors,
        attrs,
        cam,
    }
}

/// `shade` and `shade_gouraud` write every pixel without clearing first:
/// into a larger image full of NaN, and into an empty one, they agree, the
/// background colour's runs included.
#[test]
fn shading_passes_overwrite_every_pixel_of_a_stale_or_empty_image() {
    let ColouredTorus {
        positions,
        triangles,
        colors,
        attrs,
        cam,
    } = coloured_torus();
    let draws = [DrawCall::new(&positions, &triangles).with_attributes(3, &attrs)];
    let sky = Background::Color(Vec3::new(0.25, 0.5, 0.75));
    let mut r = Rasterizer::new();
    r.rasterize(&cam, &draws, &options()).unwrap();
    let stale = || {
        let mut img = Image::new(200, 100);
        img.pixels.fill(Vec3::NAN);
        img
    };
    let mut per_pixel = stale();
    r.shade(
        &draws,
        |f| Vec3::from_slice(f.attributes),
        sky,
        &mut per_pixel,
    )
    .unwrap();
    assert!(per_pixel.pixels.iter().all(|p| p.is_finite()));
    let mut stale = stale();
    let mut empty = Image::new(0, 0);
    let covered = (0..96 * 64).filter(|&i| r.gbuffer().is_covered(i)).count();
    assert!(
        covered > 500 && covered < 96 * 64 - 500,
        "{covered} covered"
    );
    for out in [&mut stale, &mut empty] {
        r.shade_gouraud(&draws, &[&colors], sky, out).unwrap();
        assert_eq!((out.width, out.height, out.pixels.len()), (96, 64, 96 * 64));
        for (i, (a, b)) in out.pixels.iter().zip(&per_pixel.pixels).enumerate() {
            assert!(
                (*a - *b).abs().max_element() < 1e-5,
                "pixel {i}: {a} vs {b}"
            );
        }
    }
}

#[test]
fn gouraud_and_per_pixel_agree_and_background_follows_the_view_ray() {
    let ColouredTorus {
        positions,
        triangles,
        colors,
        attrs,
        cam,
    } = coloured_torus();
    let draws = [DrawCall::new(&positions, &triangles).with_attributes(3, &attrs)];
    let env = |d: Vec3| d * 0.5 + Vec3::splat(0.5);
    let mut r = Rasterizer::new();
    let (mut a, mut b) = (Image::new(1, 1), Image::new(1, 1));
    r.render_gouraud(
        &cam,
        &draws,
        &[&colors],
        Background::Environment(&env),
        &options(),
        &mut a,
    )
    .unwrap();
    r.shade(
        &draws,
        |f| Vec3::from_slice(f.attributes),
        Background::Environment(&env),
        &mut b,
    )
    .unwrap();
    let g = r.gbuffer();
    for (i, (pa, pb)) in a.pixels.iter().zip(&b.pixels).enumerate() {
        assert!(
            (*pa - *pb).abs().max_element() < 1e-5,
            "pixel {i}: gouraud {pa} vs per-pixel {pb}"
        );
        if !g.is_covered(i) {
            let (_, d) = cam.ray((i % cam.width) as f32 + 0.5, (i / cam.width) as f32 + 0.5);
            assert!(
                (*pa - env(d)).abs().max_element() < 1e-5,
                "background {pa} vs {}",
                env(d)
            );
        }
    }
    // The world position of the fragment reprojects to its own pixel.
    let mut c = Image::new(1, 1);
    r.shade(
        &draws,
        |f| {
            let (o, d) = cam.ray(f.x as f32 + 0.5, f.y as f32 + 0.5);
            let off = (f.position - o).cross(d).length();
            assert!(
                off < 1e-4,
                "fragment position {} is {off} off its pixel ray",
                f.position
            );
            Vec3::ZERO
        },
        Background::Color(Vec3::ZERO),
        &mut c,
    )
    .unwrap();
}

#[test]
fn bad_input_gives_typed_errors() {
    let positions = [Vec3::ZERO, Vec3::X, Vec3::Y];
    let cam = flat_camera(16);
    let mut r = Rasterizer::new();
    let bad = [[0u32, 1, 3]];
    assert!(matches!(
        r.rasterize(&cam, &[DrawCall::new(&positions, &bad)], &options()),
        Err(RasterError::IndexOutOfRange {
            draw: 0,
            triangle: 0,
            vertex: 3,
            vertices: 3
        })
    ));
    let ok = [[0u32, 1, 2]];
    let attrs = [0.0f32; 5];
    assert!(matches!(
        r.rasterize(
            &cam,
            &[DrawCall::new(&positions, &ok).with_attributes(2, &attrs)],
            &options()
        ),
        Err(RasterError::AttributeLength { .. })
    ));
    assert!(matches!(
        r.rasterize(&flat_camera(0), &[], &options()),
        Err(RasterError::ImageSize { .. })
    ));
    let depth = RasterOptions {
        near: 0.0,
        ..options()
    };
    assert!(matches!(
        r.rasterize(&cam, &[], &depth),
        Err(RasterError::DepthRange { .. })
    ));
    let mut img = Image::new(1, 1);
    r.rasterize(&cam, &[DrawCall::new(&positions, &ok)], &options())
        .unwrap();
    assert!(matches!(
        r.shade_gouraud(
            &[DrawCall::new(&positions, &ok)],
            &[&[Vec3::ONE]],
            Background::Color(Vec3::ZERO),
            &mut img
        ),
        Err(RasterError::ColorCount { .. })
    ));
    assert!(matches!(
        r.shade(&[], |_| Vec3::ZERO, Background::Color(Vec3::ZERO), &mut img),
        Err(RasterError::DrawMismatch { .. })
    ));
    let msg = RasterError::IndexOutOfRange {
        draw: 1,
        triangle: 2,
        vertex: 9,
        vertices: 3,
    }
    .to_string();
    assert!(
        msg.contains("draw call 1") && msg.contains("vertex 9"),
        "{msg}"
    );
}
