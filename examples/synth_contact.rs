// Scratch: contact sheet of a few (view, light) images per material. Not committed.
use btfpt::btf::DirectionSet;
use btfpt::btf::synth::*;
use btfpt::io::{RgbImage, write_png_srgb};
fn main() {
    let n = 64;
    let views = vec![(0.0, 0.0), (45.0, 0.0), (60.0, 90.0), (75.0, 0.0)];
    let lights = vec![
        (0.0, 0.0),
        (45.0, 180.0),
        (60.0, 0.0),
        (60.0, 90.0),
        (75.0, 270.0),
    ];
    let s = SynthSettings {
        views: DirectionSet::from_angles_deg(views.clone()),
        lights: DirectionSet::from_angles_deg(lights.clone()),
        strata: 2,
        seed: 1,
        interreflection: true,
        indirect_clamp: 1.0,
        progress: false,
    };
    let k = 3;
    let only: Vec<String> = std::env::args().skip(1).collect();
    for m in MaterialKind::ALL.iter() {
        if !only.is_empty() && !only.iter().any(|o| o == m.name()) {
            continue;
        }
        let mut sheet = RgbImage::new(k * n * 3, k * n * 2);
        let b = measure(&m.build(n, n, 4, 1).unwrap(), &s).unwrap();
        for (r, &(v, l)) in [(0usize, 0usize), (1, 2), (1, 1), (2, 3), (3, 4), (0, 4)]
            .iter()
            .enumerate()
        {
            for y in 0..k * n {
                for x in 0..k * n {
                    sheet.set(
                        (r % 3) * k * n + x,
                        (r / 3) * k * n + y,
                        b.texel(v, l, x / k, y / k),
                    );
                }
            }
        }
        write_png_srgb(
            std::path::Path::new(&format!("/tmp/synth_{}.png", m.name())),
            &sheet,
        )
        .unwrap();
    }
}
