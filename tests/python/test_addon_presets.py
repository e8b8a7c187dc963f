"""The add-on core's engine presets (settings.presets): passed to the bake,
part of the content hash, their folders part of a complete bake."""
import os
import shutil
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "addon"))
from iblbake.core import needs as N  # noqa: E402
from iblbake.core import pipeline  # noqa: E402
from iblbake.core.settings import BakeSettings  # noqa: E402
from iblbake.core.world import IMAGE, WorldSource  # noqa: E402


def small(tmp_path, **kw):
    s = BakeSettings(out_dir=str(tmp_path / "out"), face_size=32, irradiance_size=4, lut_size=16,
                     lut_cache_dir=str(tmp_path / "cache"))
    for k, v in kw.items():
        setattr(s, k, v)
    return s


def sky(h=16, w=32):
    return (0.5 + np.random.default_rng(3).random((h, w, 3))).astype(np.float32)


def test_presets_are_baked_hashed_and_checked(tmp_path):
    src, px = WorldSource(IMAGE), sky()
    plain = pipeline.bake(src, px, small(tmp_path))
    three = pipeline.bake(src, px, small(tmp_path, presets=["three", "babylon"]))
    assert three.status == "baked" and three.content_hash != plain.content_hash
    assert sorted(three.manifest["presets"]) == ["babylon", "three"]
    assert (tmp_path / "out" / "three" / "specular.ktx2").is_file()
    assert "for babylon, three" in three.summary()
    assert pipeline.bake(src, px, small(tmp_path, presets=["three", "babylon"])).status == "unchanged"
    # A preset's folder gone: the bake is not complete any more.
    shutil.rmtree(tmp_path / "out" / "babylon")
    assert pipeline.bake(src, px, small(tmp_path, presets=["three", "babylon"])).status == "baked"
    assert pipeline.native_options(small(tmp_path, presets=["unity"]), None)["presets"] == ["unity"]


def test_presets_alone_are_something_to_bake_and_bad_ones_fail_cleanly(tmp_path):
    only_emission = N.needs_from_lobes([], 5, objects=1)  # the scene needs nothing of SPEC's outputs
    rep = pipeline.bake(WorldSource(IMAGE), sky(), small(tmp_path, presets=["filament"]), needs=only_emission)
    assert rep.status == "baked" and (tmp_path / "out" / "filament" / "ibl.ktx").is_file()
    with pytest.raises(pipeline.BakeError, match="unknown preset"):
        pipeline.bake(WorldSource(IMAGE), sky() * 2, small(tmp_path, presets=["frostbite"]))
    with pytest.raises(pipeline.BakeError, match="presets must be a list of names, not .three."):
        pipeline.bake(WorldSource(IMAGE), sky() * 2, small(tmp_path, presets="three"))
    assert (tmp_path / "out" / "filament" / "ibl.ktx").is_file()  # the earlier bake stays
