#!/usr/bin/env python3
"""Golden values of Mitsuba 3 reconstruction filters for src/render/filter.rs (radius, border, eval)."""
import mitsuba as mi, drjit as dr
mi.set_variant("llvm_ad_rgb")
xs=[0.0,0.1,0.37,0.5,0.8,1.0,1.3,1.9,2.5,2.99]
for d in [{'type':'box'},{'type':'tent'},{'type':'gaussian'},{'type':'gaussian','stddev':0.3},{'type':'mitchell'},{'type':'catmullrom'},{'type':'lanczos'},{'type':'lanczos','lobes':2},{'type':'tent','radius':1.5},{'type':'mitchell','B':0.5,'C':0.25}]:
    f=mi.load_dict(d)
    v=f.eval(mi.Float(xs))
    print(d, f.radius(), f.border_size(), f.is_box_filter(), [float(a) for a in v])
# Mitsuba's LLVM Gaussian against the exact kernel exp(-2x^2) - exp(-8): an oscillating <= 4.2e-4
import math
g = mi.load_dict({'type': 'gaussian'})
xs = [i * 0.05 for i in range(42)]
for x, a in zip(xs, g.eval(mi.Float(xs))):
    print(f"{x:.2f} {float(a):.9f} exact {math.exp(-2 * x * x) - math.exp(-8):.9f}")
