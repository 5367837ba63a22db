#!/usr/bin/env python3
"""Golden primary rays of Mitsuba 3's `perspective`, `thinlens` and `orthographic` sensors for
tests/scene_loading/sensors.rs: each case is a <sensor> element (one line), followed by rays
`sx sy ux uy  ox oy oz  dx dy dz  maxt` for film position (sx, sy) in [0, 1]^2 of the full film
and aperture sample (ux, uy). Run: .venv/bin/python sensor_golden.py > sensor_golden.txt"""
import mitsuba as mi

mi.set_variant("scalar_rgb")

FILM = '<film type="hdrfilm"><integer name="width" value="{w}"/><integer name="height" value="{h}"/><rfilter type="box"/></film>'
LOOKAT = '<transform name="to_world"><lookat origin="1, 2, 5" target="0.3, 0, -1" up="0, 1, 0"/></transform>'
SCALED = ('<transform name="to_world"><scale x="2" y="3" z="1.5"/>'
          '<lookat origin="1, 2, 5" target="0.3, 0, -1" up="0, 1, 0"/></transform>')
CASES = [
    f'<sensor type="perspective"><float name="fov" value="39.3"/>{LOOKAT}{FILM.format(w=160, h=120)}</sensor>',
    f'<sensor type="thinlens"><float name="fov" value="40"/><float name="aperture_radius" value="0.2"/>'
    f'<float name="focus_distance" value="4.5"/>{LOOKAT}{FILM.format(w=160, h=120)}</sensor>',
    f'<sensor type="thinlens"><float name="fov" value="30"/><string name="fov_axis" value="y"/>'
    f'<float name="aperture_radius" value="0.05"/><float name="focus_distance" value="2"/>'
    f'<float name="near_clip" value="0.5"/><float name="far_clip" value="50"/>{LOOKAT}{FILM.format(w=90, h=160)}</sensor>',
    f'<sensor type="thinlens"><string name="focal_length" value="35mm"/><float name="aperture_radius" value="0.1"/>'
    f'{FILM.format(w=64, h=48)}</sensor>',
    f'<sensor type="orthographic">{SCALED}{FILM.format(w=160, h=120)}</sensor>',
    f'<sensor type="orthographic"><float name="near_clip" value="0.25"/><float name="far_clip" value="20"/>'
    f'{LOOKAT}{FILM.format(w=50, h=100)}</sensor>',
]
POSITIONS = [(0.5, 0.5), (0.0, 0.0), (1.0, 1.0), (0.13, 0.71), (0.9, 0.2)]
APERTURES = [(0.5, 0.5), (0.0, 0.0), (0.99, 0.3), (0.25, 0.8), (0.6, 0.05)]

for xml in CASES:
    sensor = mi.load_string(f'<scene version="3.0.0">{xml}</scene>').sensors()[0]
    print("sensor", xml)
    for i, (sx, sy) in enumerate(POSITIONS):
        for ux, uy in APERTURES[: (len(APERTURES) if "thinlens" in xml else 1)][::1 if i % 2 == 0 else -1]:
            ray, _ = sensor.sample_ray(0.0, 0.0, mi.Point2f(sx, sy), mi.Point2f(ux, uy))
            vals = [sx, sy, ux, uy, *ray.o, *ray.d, ray.maxt]
            print(" ".join(f"{float(v):.9g}" for v in vals))
