"""The automatic parameters against the sweep, on scenes made with seeds the method was not tuned on
(it was tuned on seed 101)."""

import pytest

from geostructure.auto import choose_params
from geostructure.synthetic import observatory_scene
from geostructure.testing.autocheck import check_variant


@pytest.mark.parametrize(
    "variant,seed,size",
    [
        ("bundled", 7, 0.5),
        ("scale 0.1x", 8, 0.5),
        ("scale 10x", 9, 0.5),
        ("sparse (1/25 density)", 10, 1.0),
        ("noisy (8 cm)", 11, 0.5),
        ("sparse and noisy", 12, 1.0),
    ],
)
def test_auto_lands_near_the_best_the_sweep_finds(variant, seed, size):
    check = check_variant(variant, seed, size)
    assert check.found_auto == 6, check
    assert check.auto_ok, check


def test_the_fixed_defaults_do_not_on_a_noisy_scene():
    # sparse scenes no longer defeat them: the coplanar merge puts their pieces back together
    check = check_variant("noisy (8 cm)", 11, 0.5)
    assert not check.default_ok, check


def test_auto_choice_does_not_depend_on_scale():
    a = choose_params(observatory_scene(60_000, seed=3).cloud.local).params
    b = choose_params(observatory_scene(60_000, seed=3, scale=10).cloud.local).params
    assert a.zeta == pytest.approx(b.zeta, rel=1e-3) and a.psi == pytest.approx(b.psi, rel=0.02)
