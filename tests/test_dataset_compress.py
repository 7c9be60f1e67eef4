"""Channel omission (skymodel.compress): the greedy rule, interpolation, and loading with a channel list.

References: linear interpolation reproduces data that are linear in wavelength exactly (so greedy omission keeps
only the first 12 channels and the last one, tolerance 1e-12); a zero threshold on non-linear data keeps every
channel; a model loaded with a channel list holds only the kept channels' coefficients and its interpolated
radiance equals interpolating the full model's radiance (rtol 1e-12).
"""

import json

import numpy as np
import pytest

from widesky import skymodel
from widesky.skymodel.compress import (greedy_omission, interpolate_channels, load_compressed, omission_errors,
                               sky_radiance_all_channels, write_channel_list)
from widesky.skymodel.synthetic import write_synthetic_dataset

WL = 300.0 + 40.0 * np.arange(55)


def test_linear_spectra_keep_only_the_forced_channels():
    rng = np.random.default_rng(0)
    y = rng.uniform(1, 2, (50, 1)) + rng.uniform(0, 1e-3, (50, 1)) * WL[None, :]
    kept = greedy_omission(y, WL, 1e-9)
    assert kept.tolist() == list(range(12)) + [54]
    assert omission_errors(y, WL, kept).max() < 1e-12


def test_zero_threshold_on_curved_spectra_keeps_everything():
    y = np.exp(-((WL - 900.0) / 300.0) ** 2)[None, :] + 0.1
    assert greedy_omission(y, WL, 0.0).size == 55


def test_error_grows_with_threshold_and_respects_it():
    rng = np.random.default_rng(1)
    y = (np.exp(-((WL - 700.0) / 500.0) ** 2) + 0.05 * np.sin(WL / 90.0) ** 2)[None, :] * rng.uniform(0.5, 2, (20, 1))
    sizes = []
    for t in (0.001, 0.01, 0.05, 0.2):
        kept = greedy_omission(y, WL, t)
        assert omission_errors(y, WL, kept).max() <= t + 1e-12
        sizes.append(kept.size)
    assert sizes == sorted(sizes, reverse=True)


def test_interpolate_channels_holds_ends():
    v = np.array([[1.0, 3.0]])
    out = interpolate_channels(v, [400.0, 500.0], [300.0, 400.0, 450.0, 500.0, 600.0])
    np.testing.assert_allclose(out, [[1.0, 1.0, 2.0, 3.0, 3.0]], rtol=1e-15)


def test_loading_with_a_channel_list(tmp_path):
    path = write_synthetic_dataset(tmp_path / "s.dat", visibilities=(20, 131.8), albedos=(0.0, 1.0), n_channels=55,
                                   rank=2, n_sun=8, n_zen=8, n_emph=6, seed=2)
    full = skymodel.load_dataset(path)
    kept = np.array(list(range(12)) + [20, 30, 40, 54])
    cl = write_channel_list(tmp_path / "c.json", kept, full.wavelengths, 0.15, path)
    assert json.loads(cl.read_text())["kept_channels"] == kept.tolist()
    small = load_compressed(path, cl)
    dirs = skymodel.directions_from_angles([0.0, 40.0, 80.0], [0.0, 120.0, 250.0])
    ours = sky_radiance_all_channels(small, dirs, 30.0, 180.0, 50.0, 0.3)
    ref_full = skymodel.sky_radiance(full, dirs, 30.0, 180.0, 50.0, 0.3)
    assert ours.shape == ref_full.shape
    np.testing.assert_allclose(ours[:, kept], ref_full[:, kept], rtol=1e-12)
    np.testing.assert_allclose(ours, interpolate_channels(ref_full[:, kept], full.wavelengths[kept], full.wavelengths),
                               rtol=1e-12)
    assert small.selection_bytes() < 0.4 * full.selection_bytes()  # 16 of 55 channels (+ the shared U table)
    with pytest.raises(ValueError, match="every channel"):
        sky_radiance_all_channels(small, dirs, 30.0, 180.0, 50.0, 0.3, channels=[0])


def test_compress_cli_writes_a_channel_list(tmp_path, capsys):
    from widesky.cli import main

    path = write_synthetic_dataset(tmp_path / "s.dat", visibilities=(20, 131.8), albedos=(0.0, 1.0), n_channels=55,
                                   rank=2, n_sun=8, n_zen=8, n_emph=6, seed=2)
    out = tmp_path / "ch.json"
    assert main(["dataset", "compress", str(path), "--max-error", "0.15", "--directions", "50", "-o", str(out)]) == 0
    d = json.loads(out.read_text())
    assert d["kept_channels"][:12] == list(range(12)) and d["kept_channels"][-1] == 54
    assert "kept" in capsys.readouterr().out
