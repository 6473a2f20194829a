//! Issue 11 reported isolated bright pixels beside fog silhouettes. Guard:
//! on the default scene in fog with four point lights, antialiased as the
//! viewer's still frames are, no pixel at an object edge (itself or a
//! 4-neighbour partly covered) is more than 1.3× brighter than every one of
//! its eight neighbours.

use relight_fog::{FogOptions, FogRelighter, default_scene_lights};
use relight_render::method::{FrameRequest, Relighter, render_frame};
use relight_render::{Medium, NoProgress};

#[test]
fn no_isolated_bright_pixels_at_fog_silhouettes() {
    let mut s = relight_scene::default_scene(320, 180);
    s.medium = Some(Medium {
        beta: 0.1,
        albedo: 1.0,
        radius: 10.0,
    });
    s.point_lights = default_scene_lights(4);
    let mut m = FogRelighter::new(FogOptions {
        env_order: 3,
        ..FogOptions::default()
    })
    .unwrap();
    m.prepare(&s, &NoProgress).unwrap();
    let request = FrameRequest::new(s.camera).with_aa(2);
    let out = render_frame(&mut m, &s, &request, &NoProgress).unwrap();
    let cov = out.coverage.unwrap().coverage.clone();
    let img = &out.image;
    let w = img.width;
    let lum = |x: usize, y: usize| img.pixels[y * w + x].element_sum();
    let mut edges = 0;
    let mut outliers = Vec::new();
    for y in 1..img.height - 1 {
        for x in 1..w - 1 {
            let c = [
                cov[y * w + x],
                cov[y * w + x - 1],
                cov[y * w + x + 1],
                cov[(y - 1) * w + x],
                cov[(y + 1) * w + x],
            ];
            if !(c.iter().any(|&c| c < 1.0) && c.iter().any(|&c| c > 0.0)) {
                continue;
            }
            edges += 1;
            let mut brightest = 0.0f32;
            for (dx, dy) in (0..3).flat_map(|dy| (0..3).map(move |dx| (dx, dy))) {
                if (dx, dy) != (1, 1) {
                    brightest = brightest.max(lum(x + dx - 1, y + dy - 1));
                }
            }
            let l = lum(x, y);
            if l > 0.05 && l > 1.3 * brightest {
                outliers.push((x, y, l, brightest));
            }
        }
    }
    assert!(edges > 500, "only {edges} edge pixels");
    assert!(outliers.is_empty(), "{outliers:?}");
}
