"""Regenerates spectrum_golden.txt: the RGB values Mitsuba 3.9.1's RGB variants give a
<spectrum> with a wavelength list (or a uniform one) when a scene is loaded, the reference that
src/math/cie1931.rs and tests/scene_loading/mitsuba_xml.rs test against.

    /path/to/venv/bin/python reference-images/spectrum_golden.py > reference-images/spectrum_golden.txt

Line format: <use> <r> <g> <b> <spectrum value>, with <use> one of
    reflectance  a diffuse bsdf's "reflectance" (bounded: D65-weighted, clipped to [0, 1])
    unbounded    a conductor's "eta" (D65-weighted, negatives clipped)
    emitter      an area light's "radiance" (no D65 weighting, negatives clipped)
The spectra are those of Mitsuba's Cornell box (scenes/cbox/cbox.xml of mitsuba-data) and a few
made up to reach the clipping and interpolation edge cases.
"""
import mitsuba as mi

mi.set_variant("scalar_rgb")
mi.set_log_level(mi.LogLevel.Error)  # no clipping warnings on stdout

CBOX_WHITE = ("400:0.343, 404:0.445, 408:0.551, 412:0.624, 416:0.665, 420:0.687, 424:0.708, "
              "428:0.723, 432:0.715, 436:0.71, 440:0.745, 444:0.758, 448:0.739, 452:0.767, "
              "456:0.777, 460:0.765, 464:0.751, 468:0.745, 472:0.748, 476:0.729, 480:0.745, "
              "484:0.757, 488:0.753, 492:0.75, 496:0.746, 500:0.747, 504:0.735, 508:0.732, "
              "512:0.739, 516:0.734, 520:0.725, 524:0.721, 528:0.733, 532:0.725, 536:0.732, "
              "540:0.743, 544:0.744, 548:0.748, 552:0.728, 556:0.716, 560:0.733, 564:0.726, "
              "568:0.713, 572:0.74, 576:0.754, 580:0.764, 584:0.752, 588:0.736, 592:0.734, "
              "596:0.741, 600:0.74, 604:0.732, 608:0.745, 612:0.755, 616:0.751, 620:0.744, "
              "624:0.731, 628:0.733, 632:0.744, 636:0.731, 640:0.712, 644:0.708, 648:0.729, "
              "652:0.73, 656:0.727, 660:0.707, 664:0.703, 668:0.729, 672:0.75, 676:0.76, "
              "680:0.751, 684:0.739, 688:0.724, 692:0.73, 696:0.74, 700:0.737")
CBOX_RED = ("400:0.04, 404:0.046, 408:0.048, 412:0.053, 416:0.049, 420:0.05, 424:0.053, "
            "428:0.055, 432:0.057, 436:0.056, 440:0.059, 444:0.057, 448:0.061, 452:0.061, "
            "456:0.06, 460:0.062, 464:0.062, 468:0.062, 472:0.061, 476:0.062, 480:0.06, "
            "484:0.059, 488:0.057, 492:0.058, 496:0.058, 500:0.058, 504:0.056, 508:0.055, "
            "512:0.056, 516:0.059, 520:0.057, 524:0.055, 528:0.059, 532:0.059, 536:0.058, "
            "540:0.059, 544:0.061, 548:0.061, 552:0.063, 556:0.063, 560:0.067, 564:0.068, "
            "568:0.072, 572:0.08, 576:0.09, 580:0.099, 584:0.124, 588:0.154, 592:0.192, "
            "596:0.255, 600:0.287, 604:0.349, 608:0.402, 612:0.443, 616:0.487, 620:0.513, "
            "624:0.558, 628:0.584, 632:0.62, 636:0.606, 640:0.609, 644:0.651, 648:0.612, "
            "652:0.61, 656:0.65, 660:0.638, 664:0.627, 668:0.62, 672:0.63, 676:0.628, "
            "680:0.642, 684:0.639, 688:0.657, 692:0.639, 696:0.635, 700:0.642")
CBOX_GREEN = ("400:0.092, 404:0.096, 408:0.098, 412:0.097, 416:0.098, 420:0.095, 424:0.095, "
              "428:0.097, 432:0.095, 436:0.094, 440:0.097, 444:0.098, 448:0.096, 452:0.101, "
              "456:0.103, 460:0.104, 464:0.107, 468:0.109, 472:0.112, 476:0.115, 480:0.125, "
              "484:0.14, 488:0.16, 492:0.187, 496:0.229, 500:0.285, 504:0.343, 508:0.39, "
              "512:0.435, 516:0.464, 520:0.472, 524:0.476, 528:0.481, 532:0.462, 536:0.447, "
              "540:0.441, 544:0.426, 548:0.406, 552:0.373, 556:0.347, 560:0.337, 564:0.314, "
              "568:0.285, 572:0.277, 576:0.266, 580:0.25, 584:0.23, 588:0.207, 592:0.186, "
              "596:0.171, 600:0.16, 604:0.148, 608:0.141, 612:0.136, 616:0.13, 620:0.126, "
              "624:0.123, 628:0.121, 632:0.122, 636:0.119, 640:0.114, 644:0.115, 648:0.117, "
              "652:0.117, 656:0.118, 660:0.12, 664:0.122, 668:0.128, 672:0.132, 676:0.139, "
              "680:0.144, 684:0.146, 688:0.15, 692:0.152, 696:0.157, 700:0.159")
FLAT = "400:0.78, 500:0.78, 600:0.78, 700:0.78"
LIGHT = "400:0, 500:8, 600:15.6, 700:18.4"
ETA = "300:1.8, 400:1.65, 500:0.9, 600:0.2, 700:0.16, 800:0.18"
K = "300:1.92, 400:1.95, 500:1.95, 600:2.97, 700:3.8, 800:5.12"

CASES = [
    ("reflectance", CBOX_WHITE), ("reflectance", CBOX_RED), ("reflectance", CBOX_GREEN),
    ("reflectance", FLAT),
    # Out of gamut: a saturated blue-green clipped to [0, 1] (negative red), values above 1.
    ("reflectance", "450:0, 500:1, 520:1, 560:0"), ("reflectance", "380:1.6, 780:1.4"),
    # Irregular spacing, beyond the CIE range on both sides, whitespace-only separators.
    ("reflectance", "300:0.2 455.5:0.9 610:0.1 900:0.5"),
    ("unbounded", ETA), ("unbounded", K), ("unbounded", "450:0, 500:1, 520:1, 560:0"),
    ("emitter", LIGHT), ("emitter", FLAT), ("emitter", "450:0, 500:1, 520:1, 560:0"),
    ("emitter", "3.5"),
]


def load(use, value):
    spec = f'<spectrum name="{{}}" value="{value}"/>'
    if use == "reflectance":
        obj = mi.load_string(f'<bsdf version="3.0.0" type="diffuse">{spec.format("reflectance")}</bsdf>')
        key = "reflectance.value"
    elif use == "unbounded":
        obj = mi.load_string(f'<bsdf version="3.0.0" type="conductor">{spec.format("eta")}</bsdf>')
        key = "eta.value"
    else:
        obj = mi.load_string(f'<emitter version="3.0.0" type="constant">{spec.format("radiance")}</emitter>')
        key = "radiance.value"
    return mi.traverse(obj)[key]


for use, value in CASES:
    c = load(use, value)
    print(use, *("%.9g" % float(v) for v in c), value)
