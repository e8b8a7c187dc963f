"""The sun as a light (issue 27) through the module and the CLI: the files
(sun.json, sun.gltf, each preset's light), the engines' conventions, the
manifest, and bakes without the option unchanged."""
import json
import os
import subprocess
import sys

import numpy as np
import pytest

import iblbake_core as ib

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "addon"))
from iblbake.core import describe  # noqa: E402

CLI = os.environ.get("IBLBAKE_CLI", os.path.join(os.path.dirname(__file__), "..", "..", "build", "native", "iblbake"))
STUDIO = "/usr/share/blender/datafiles/studiolights/world/"
SMALL = dict(face_size=32, irradiance_size=8, lut_size=16)


def blender_dirs(w, h):
    lat = (0.5 - (np.arange(h) + 0.5) / h) * np.pi
    phi = (0.5 - (np.arange(w) + 0.5) / w) * 2 * np.pi
    return np.stack([np.cos(lat)[:, None] * np.cos(phi)[None, :], np.cos(lat)[:, None] * np.sin(phi)[None, :],
                     np.repeat(np.sin(lat)[:, None], w, 1)], -1)


def sun_sky(w=256, h=128, direction=(0.5, -0.6, 0.62), radius_deg=2.0, radiance=(5000.0, 4500.0, 3500.0)):
    """A smooth sky and a hard-edged disc (texel centres inside it)."""
    d = blender_dirs(w, h)
    img = (0.6 + 0.4 * d[..., 2:3]) * np.array([1.0, 1.05, 1.2])
    c = np.asarray(direction) / np.linalg.norm(direction)
    img[d @ c >= np.cos(np.radians(radius_deg))] += radiance
    return np.ascontiguousarray(img, dtype=np.float32), c


def quat_rotate(q, v):
    x, y, z, w = q
    u = np.array([x, y, z])
    v = np.asarray(v, dtype=float)
    return 2 * np.dot(u, v) * u + (w * w - np.dot(u, u)) * v + 2 * w * np.cross(u, v)


def test_option_row():
    row = next(r for r in ib.options() if r["name"] == "sun")
    assert row["kind"] == "choice" and row["default"] == "off" and row["cli"] == "--sun" and row["blender"]
    assert [c["value"] for c in row["choices"]] == ["off", "split"]
    with pytest.raises(ValueError, match="sun"):
        ib.check_options(sun="on")


def test_split_files_and_every_engines_light(tmp_path):
    img, c = sun_sky()
    presets = [p["name"] for p in ib.presets()]
    res = ib.bake(img, str(tmp_path / "out"), sun="split", presets=presets, **SMALL)
    sun = res["sun"]
    assert sun["found"], sun["why"]
    assert np.degrees(np.arccos(np.clip(np.dot(sun["direction"], c), -1, 1))) < 0.3
    out = tmp_path / "out"
    with open(out / "sun.json") as f:
        assert json.load(f) == sun == res["manifest"]["sun"]
    assert res["manifest"]["options"]["sun"] == "split"
    assert res["manifest"]["files"]["sun.json"]["bytes"] == os.path.getsize(out / "sun.json")
    # colour x intensity = E; the colour's brightest channel is 1
    e = np.asarray(sun["illuminance"])
    np.testing.assert_allclose(np.asarray(sun["color"]) * e.max(), e, rtol=1e-12)
    assert max(sun["color"]) == 1.0
    assert sun["illuminance_lux"] == pytest.approx(float(e @ [0.2126, 0.7152, 0.0722]))
    # sun.gltf: one node, one directional light, its -Z along the light's travel (glTF axes: x, z, -y)
    with open(out / "sun.gltf") as f:
        g = json.load(f)
    assert g["asset"]["version"] == "2.0" and g["extensionsUsed"] == ["KHR_lights_punctual"]
    (light,) = g["extensions"]["KHR_lights_punctual"]["lights"]
    assert light["type"] == "directional" and all(0 <= v <= 1 for v in light["color"])
    np.testing.assert_allclose(np.asarray(light["color"]) * light["intensity"], e, rtol=1e-12)
    (node,) = g["nodes"]
    assert g["scenes"][g["scene"]]["nodes"] == [0] and node["extensions"]["KHR_lights_punctual"]["light"] == 0
    bx, by, bz = sun["direction"]
    gl = np.array([bx, bz, -by])
    np.testing.assert_allclose(quat_rotate(node["rotation"], [0, 0, -1]), -gl, atol=1e-12)
    # each preset: its sun.json, the direction in its world (three, bevy: glTF's; babylon, unity: x mirrored)
    want = {"three": gl, "khronos": gl, "bevy": gl, "filament": gl, "cesium": gl, "source": gl,
            "babylon": gl * [-1, 1, 1], "unity": gl * [-1, 1, 1]}
    for name in presets:
        entry = res["manifest"]["presets"][name]
        assert entry["files"]["sun"] == "sun.json"
        with open(out / entry["dir"] / "sun.json") as f:
            light = json.load(f)
        assert light == entry["sun"] == sun["engines"][name]
        np.testing.assert_allclose(light["direction"], want[name], atol=1e-12, err_msg=name)
        np.testing.assert_allclose(light["light_direction"], -want[name], atol=1e-12)
        scale = 1 / np.pi if name == "unity" else 1.0
        np.testing.assert_allclose(np.asarray(light["color"]) * light["intensity"], e * scale, rtol=1e-12)
    assert sun["engines"]["three"]["verified"]
    # Blender: Strength x colour = E, Angle = the diameter, its -Z turned onto -direction
    lamp = sun["blender"]
    np.testing.assert_allclose(np.asarray(lamp["color"]) * lamp["strength"], e, rtol=1e-12)
    rx, ry, rz = np.radians(lamp["rotation_euler_deg"])
    X = np.array([[1, 0, 0], [0, np.cos(rx), -np.sin(rx)], [0, np.sin(rx), np.cos(rx)]])
    Y = np.array([[np.cos(ry), 0, np.sin(ry)], [0, 1, 0], [-np.sin(ry), 0, np.cos(ry)]])
    Z = np.array([[np.cos(rz), -np.sin(rz), 0], [np.sin(rz), np.cos(rz), 0], [0, 0, 1]])
    np.testing.assert_allclose(Z @ Y @ X @ [0, 0, -1], -np.asarray(sun["direction"]), atol=1e-9)
    # the panel's sentence
    assert describe.sun_sentence(sun).startswith("Sun at %.0f\u00b0 elevation" % sun["elevation_deg"])
    assert describe.sun_sentence({"found": False, "why": "x"}) == "No sun found"
    assert describe.sun_sentence(None) == ""


def test_sun_free_bake_is_the_bake_of_the_sun_free_source(tmp_path):
    """bake(sun='split') = bake() of split_sun's sun-free image, file for file."""
    img, _ = sun_sky()
    free, sun = ib.split_sun(img)
    assert sun["found"] and free.shape == img.shape
    changed = np.any(free != img, -1)
    assert 0 < changed.sum() < 200 and (free <= img).all() and (free >= 0).all()
    a = ib.bake(img, sun="split", **SMALL)
    b = ib.bake(free, **SMALL)
    np.testing.assert_array_equal(a["irradiance"], b["irradiance"])
    for x, y in zip(a["specular"], b["specular"]):
        np.testing.assert_array_equal(x, y)
    np.testing.assert_allclose(a["sh9"], b["sh9"], rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(a["brdf_lut"], b["brdf_lut"])  # the LUT never depends on the environment


def test_no_sun_and_sun_off(tmp_path):
    """A sky without a sun: found false, the reason, sun.json alone, the same
    outputs as without the option; with the option off: no sun file, no key."""
    d = blender_dirs(128, 64)
    sky = np.ascontiguousarray((0.6 + 0.4 * d[..., 2:3]) * np.array([1.0, 1.0, 1.1]), dtype=np.float32)
    a = ib.bake(sky, str(tmp_path / "split"), sun="split", **SMALL)
    b = ib.bake(sky, str(tmp_path / "off"), **SMALL)
    assert not a["sun"]["found"] and a["sun"]["why"].startswith("no compact source")
    assert os.path.isfile(tmp_path / "split" / "sun.json") and not os.path.exists(tmp_path / "split" / "sun.gltf")
    np.testing.assert_array_equal(a["irradiance"], b["irradiance"])
    assert b["sun"] is None and "sun" not in b["manifest"] and "sun" not in b["manifest"]["options"]
    assert sorted(os.listdir(tmp_path / "off")) == sorted(set(os.listdir(tmp_path / "split")) - {"sun.json"})
    # a plain colour has no sun
    c = ib.bake_constant([0.5, 0.5, 0.5], sun="split", **SMALL)
    assert not c["sun"]["found"]


@pytest.mark.skipif(not os.path.isfile(STUDIO + "sunset.exr"), reason="Blender's studio lights are not installed")
def test_cli_sun_split(tmp_path):
    p = subprocess.run([CLI, "bake", STUDIO + "sunset.exr", "-o", str(tmp_path / "s"), "--sun", "split",
                        "--face-size", "32", "--irradiance-size", "8", "--lut-size", "16", "--preset", "three"],
                       capture_output=True, text=True, check=True)
    assert "sun       sun at " in p.stdout, p.stdout
    with open(tmp_path / "s" / "manifest.json") as f:
        m = json.load(f)
    assert m["sun"]["found"] and os.path.isfile(tmp_path / "s" / "sun.gltf")
    assert m["presets"]["three"]["files"]["sun"] == "sun.json"
    p = subprocess.run([CLI, "bake", STUDIO + "interior.exr", "-o", str(tmp_path / "i"), "--sun", "split",
                        "--face-size", "32", "--irradiance-size", "8", "--lut-size", "16"],
                       capture_output=True, text=True, check=True)
    assert "sun       none: no dominant source" in p.stdout, p.stdout
    p = subprocess.run([CLI, "bake", STUDIO + "sunset.exr", "-o", str(tmp_path / "x"), "--sun", "on"],
                       capture_output=True, text=True)
    assert p.returncode == 1 and "sun" in p.stderr
