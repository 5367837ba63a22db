"""btfpt.Btf: batched evaluation, pdf and sampling against the scalar renderer path bit for bit,
the material's summary, and bad input."""

import numpy as np
import pytest

import btfpt


def random_queries(n, seed=0, below=0.1):
    """n queries with uniform uv, cosine-ish directions; a fraction `below` under the horizon."""
    rng = np.random.default_rng(seed)

    def dirs():
        v = rng.normal(size=(n, 3))
        v[:, 2] = np.abs(v[:, 2])
        flip = rng.random(n) < below
        v[flip, 2] *= -1
        return (v / np.linalg.norm(v, axis=1, keepdims=True)).astype(np.float32)

    uv = rng.random((n, 2)).astype(np.float32) * 3 - 1
    return uv, dirs(), dirs(), rng.random(n).astype(np.float32), rng.random((n, 2)).astype(np.float32)


@pytest.mark.parametrize("which", ["plmc", "data"])
def test_batched_equals_scalar_renderer_path(material, which):
    btf = btfpt.Btf.open(material[which], uv_scale=1.5)
    # 1000 queries: groups of 16 with a ragged tail, spread over several rayon tasks.
    uv, wi, wo, u1, u2 = random_queries(1000 + 7)
    b, pdf = btf.eval_pdf(uv, wi, wo)
    ref_b, ref_f, ref_pdf, ref_swo, ref_sw, ref_spdf = btf._reference(uv, wi, wo, u1, u2)
    assert b.dtype == np.float32 and b.shape == (1007, 3) and pdf.shape == (1007,)
    np.testing.assert_array_equal(b, ref_b)
    np.testing.assert_array_equal(pdf, ref_pdf)
    np.testing.assert_array_equal(btf.eval(uv, wi, wo), ref_b)
    np.testing.assert_array_equal(btf.pdf(uv, wi, wo), ref_pdf)
    # f·cos = B/π exactly as the renderer divides.
    np.testing.assert_array_equal(b * np.float32(1 / np.pi), ref_f)
    swo, sw, spdf = btf.sample(uv, wi, u1, u2)
    np.testing.assert_array_equal(swo, ref_swo)
    np.testing.assert_array_equal(sw, ref_sw)
    np.testing.assert_array_equal(spdf, ref_spdf)
    # Something was evaluated and something is zero below the horizon.
    assert (b > 0).any() and ((wi[:, 2] <= 0) | (wo[:, 2] <= 0)).any()
    assert (b[(wi[:, 2] <= 0) | (wo[:, 2] <= 0)] == 0).all()
    assert (spdf[wi[:, 2] <= 0] == 0).all() and (spdf > 0).sum() > 800


def test_float64_input_is_rounded_like_float32(material):
    btf = btfpt.Btf.open(material["plmc"])
    uv, wi, wo, _, _ = random_queries(50, seed=3)
    np.testing.assert_array_equal(
        btf.eval(uv.astype(np.float64), wi.astype(np.float64), wo.astype(np.float64)), btf.eval(uv, wi, wo)
    )


def test_summary_and_texel_image(material):
    raw = btfpt.Btf.open(material["data"])
    fit = btfpt.Btf.open(material["plmc"])
    assert (raw.kind, fit.kind) == ("raw", "plmc")
    assert raw.size == fit.size == (8, 8)
    assert raw.views.shape == raw.lights.shape == fit.views.shape == (81, 3)
    np.testing.assert_allclose(np.linalg.norm(fit.lights, axis=1), 1, atol=1e-6)
    # model= finds the other representation next to the file.
    assert btfpt.Btf.open(material["data"], model="plmc").kind == "plmc"
    a, b = raw.texel_image(0, 5), fit.texel_image(0, 5)
    assert a.shape == b.shape == (8, 8, 3) and a.dtype == np.float32
    # The fit reproduces the measured image to within a few per cent of its level.
    assert np.abs(a - b).mean() < 0.1 * a.mean()
    with pytest.raises(btfpt.errors.InvalidArgumentError, match="view 81"):
        raw.texel_image(81, 0)


def test_bad_arrays_name_the_argument(material):
    btf = btfpt.Btf.open(material["plmc"])
    uv, wi, wo, u1, u2 = random_queries(8)
    with pytest.raises(btfpt.errors.InvalidArgumentError, match=r"wi: expected an array of shape \(N, 3\)"):
        btf.eval(uv, wi[:, :2], wo)
    with pytest.raises(TypeError, match="uv: expected float32 or float64 values, got dtype int64"):
        btf.eval(np.zeros((8, 2), dtype=np.int64), wi, wo)
    with pytest.raises(btfpt.errors.InvalidArgumentError, match="wo has 7 rows but uv has 8"):
        btf.eval(uv, wi, wo[:7])
    bad = wo.copy()
    bad[3, 0] = np.nan
    with pytest.raises(btfpt.errors.InvalidArgumentError, match=r"wo\[3\] = .* is not finite"):
        btf.pdf(uv, wi, bad)
    with pytest.raises(btfpt.errors.InvalidArgumentError, match=r"wi\[0\] = .* is not a unit direction"):
        btf.eval(uv, wi * 2, wo)
    with pytest.raises(btfpt.errors.InvalidArgumentError, match=r"sample1\[0\] = .* is not in \[0, 1\]"):
        btf.sample(uv, wi, u1 + 1, u2)
    assert isinstance(btfpt.errors.InvalidArgumentError("x"), (btfpt.Error, ValueError))


def test_bad_files_name_the_file(material, tmp_path):
    with pytest.raises(btfpt.errors.MissingFileError, match="nope.plmc") as e:
        btfpt.Btf.open(tmp_path / "nope.plmc")
    assert isinstance(e.value, FileNotFoundError)
    corrupt = tmp_path / "corrupt.plmc"
    corrupt.write_bytes(material["plmc"].read_bytes()[:200])
    with pytest.raises(btfpt.errors.FormatError, match="corrupt.plmc"):
        btfpt.Btf.open(corrupt)
    with pytest.raises(btfpt.errors.InvalidArgumentError, match='btf model "pca" is not one of raw, lm, plm, plmc'):
        btfpt.Btf.open(material["plmc"], model="pca")
    with pytest.raises(btfpt.errors.FormatError, match="no lm data for this material"):
        btfpt.Btf.open(material["data"], model="lm")
