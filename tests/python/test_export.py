"""Engine presets end to end: the CLI and the module write every preset, and
the files read back with readers that are not ours (zstandard, Pillow's PNG
decoder, OpenImageIO where it reads DDS; KTX2 / KTX1 / DDS headers parsed here
from their specifications with struct) hold the SPEC bake's texels after each
preset's mirror, within the format's rounding."""
import json
import os
import shutil
import struct
import subprocess
import zlib  # noqa: F401  (Pillow decodes the PNGs)

import numpy as np
import pytest

import iblbake_core as ib

CLI = os.environ.get("IBLBAKE_CLI") or os.path.join(os.path.dirname(__file__), "..", "..", "build", "native", "iblbake")
SIX = ["khronos", "bevy", "three", "filament", "babylon", "unity"]
FACE = 32


def run(*args):
    return subprocess.run([CLI, *args], capture_output=True, text=True)


def source(w=256, h=128):
    """A smooth source with a bright spot, so that every level differs."""
    y, x = np.mgrid[0:h, 0:w].astype(np.float32)
    img = np.stack([1.0 + 0.5 * np.sin(x / w * 2 * np.pi), 1.0 + 0.5 * np.cos(y / h * np.pi),
                    0.5 + x / w], axis=-1).astype(np.float32)
    img[h // 3:h // 3 + 4, w // 5:w // 5 + 4] = 300.0
    return img


@pytest.fixture(scope="module")
def bake_dir(tmp_path_factory):
    out = tmp_path_factory.mktemp("export") / "out"
    res = ib.bake(source(), str(out), face_size=FACE, irradiance_size=8, lut_size=32,
                  presets=SIX + ["cesium", "source"], formats=["exr"], float32=False)
    return out, res


# --- SPEC cubes and the mirrors, written here from ENGINES.md's table -------

def cross_cube(path):
    """(6, N, N, 3) from a SPEC horizontal cross (the layout of SPEC section 2)."""
    img = ib.read_image(str(path))
    n = img.shape[1] // 4
    cells = [(2, 1), (0, 1), (1, 0), (1, 2), (1, 1), (3, 1)]
    return np.stack([img[r * n:(r + 1) * n, c * n:(c + 1) * n] for c, r in cells])


def mirrored(cube, mirror):
    """ENGINES.md section 1: x swaps +X/-X and flips every face left-right; z
    swaps +Z/-Z, flips the X and Z faces left-right and the Y faces top-bottom."""
    if mirror == "none":
        return cube
    out = np.empty_like(cube)
    for f in range(6):
        if mirror == "x":
            g = {0: 1, 1: 0}.get(f, f)
            out[f] = cube[g][:, ::-1]
        else:
            g = {4: 5, 5: 4}.get(f, f)
            out[f] = cube[g][::-1, :] if f in (2, 3) else cube[g][:, ::-1]
    return out


def half(a):
    return a.astype(np.float16).astype(np.float32)


# --- containers, parsed from their specifications ---------------------------

def ktx2_levels(data):
    """(vkFormat, supercompression, [(uncompressed bytes of level m)...]) with
    Zstandard levels decompressed by the zstandard package."""
    assert data[:12] == b"\xabKTX 20\xbb\r\n\x1a\n"
    vk, type_size, w, h, d, layers, faces, levels, scheme = struct.unpack_from("<9I", data, 12)
    assert (w, h, d, layers, faces) == (w, w, 0, 0, 6)
    out = []
    for m in range(levels):
        off, length, raw = struct.unpack_from("<3Q", data, 80 + 24 * m)
        blob = data[off:off + length]
        if scheme == 2:
            import zstandard
            blob = zstandard.ZstdDecompressor().decompress(blob, max_output_size=raw)
        assert len(blob) == raw
        out.append(blob)
    return vk, scheme, w, out


def e5b9g9r9(words):
    """EXT_texture_shared_exponent: (m + 0) 2^(e - 15 - 9) per channel."""
    e = (words >> 27).astype(np.int32) - 24
    return np.stack([((words >> (9 * c)) & 511).astype(np.float64) * np.exp2(e) for c in range(3)], -1)


def test_every_preset_wrote_its_files(bake_dir):
    out, res = bake_dir
    m = res["manifest"]
    assert sorted(m["presets"]) == sorted(SIX + ["cesium", "source"])
    for name, entry in m["presets"].items():
        for role, f in entry["files"].items():
            assert (out / name / f).is_file(), (name, role)
    # The written manifest says the same.
    assert json.loads((out / "manifest.json").read_text())["presets"] == m["presets"]


def test_khronos_ktx2_is_the_spec_chain_unchanged(bake_dir):
    out, res = bake_dir
    vk, scheme, n0, levels = ktx2_levels((out / "khronos" / "specular.ktx2").read_bytes())
    assert (vk, scheme, n0, len(levels)) == (97, 0, FACE, 6)  # RGBA16F, SPEC's 6 levels of a 32 face
    for m, blob in enumerate(levels):
        n = max(1, FACE >> m)
        got = np.frombuffer(blob, np.float16).astype(np.float32).reshape(6, n, n, 4)
        want = cross_cube(out / f"specular_{m}.exr")  # half EXR: the same halves
        np.testing.assert_array_equal(got[..., :3], want)
        assert np.all(got[..., 3] == 1.0)
    _, _, _, diffuse = ktx2_levels((out / "khronos" / "diffuse.ktx2").read_bytes())
    got = np.frombuffer(diffuse[0], np.float16).astype(np.float32).reshape(6, 8, 8, 4)
    np.testing.assert_array_equal(got[..., :3], cross_cube(out / "irradiance.exr"))


def test_bevy_ktx2_is_z_mirrored_e5_in_zstd(bake_dir):
    out, res = bake_dir
    vk, scheme, n0, levels = ktx2_levels((out / "bevy" / "specular.ktx2").read_bytes())
    assert (vk, scheme) == (123, 2)
    for m, blob in enumerate(levels):
        n = max(1, FACE >> m)
        got = e5b9g9r9(np.frombuffer(blob, "<u4")).reshape(6, n, n, 3)
        want = mirrored(cross_cube(out / f"specular_{m}.exr"), "z").astype(np.float64)
        tol = want.max(axis=-1, keepdims=True) * 2.0 ** -8 + 1e-30  # a shared exponent, 9-bit mantissas
        assert np.all(np.abs(got - want) <= tol), m
    # Negative control: without the mirror the texels disagree.
    got0 = e5b9g9r9(np.frombuffer(levels[0], "<u4")).reshape(6, FACE, FACE, 3)
    assert not np.allclose(got0, cross_cube(out / "specular_0.exr"), rtol=0.01)


def test_three_ktx2_is_x_mirrored_at_filaments_roughness(bake_dir):
    out, res = bake_dir
    entry = res["manifest"]["presets"]["three"]
    vk, scheme, n0, levels = ktx2_levels((out / "three" / "specular.ktx2").read_bytes())
    assert (vk, len(levels)) == (97, 2)  # 32 -> 16
    r = [l["roughness"] for l in entry["specular"]]
    assert r == [0.0, 1.0]  # T = 1: 1 - sqrt(1 - m / T)
    level0 = np.frombuffer(levels[0], np.float16).astype(np.float32).reshape(6, FACE, FACE, 4)
    np.testing.assert_array_equal(level0[..., :3], mirrored(cross_cube(out / "specular_0.exr"), "x"))
    # SH for a LightProbe: SPEC's sh9 unchanged, coefficient by coefficient.
    np.testing.assert_allclose(np.array(entry["sh"]["coefficients"]).reshape(9, 3).T, res["sh9"], rtol=1e-12)


def test_unity_dds_is_x_mirrored_face_major(bake_dir):
    out, res = bake_dir
    data = (out / "unity" / "specular.dds").read_bytes()
    assert data[:4] == b"DDS "
    height, width, pitch, depth, mips = struct.unpack_from("<5I", data, 12)
    assert data[84:88] == b"DX10"
    dxgi, dim, misc, size = struct.unpack_from("<4I", data, 128)
    assert (dxgi, dim, misc, size, mips, width) == (10, 3, 4, 1, 6, FACE)
    at = 148
    faces0 = []
    for f in range(6):  # each face with its whole chain
        for m in range(mips):
            n = max(1, FACE >> m)
            texels = np.frombuffer(data, np.float16, n * n * 4, at).astype(np.float32).reshape(n, n, 4)
            if m == 0:
                faces0.append(texels[..., :3])
            at += n * n * 8
    assert at == len(data)
    np.testing.assert_array_equal(np.stack(faces0), mirrored(cross_cube(out / "specular_0.exr"), "x"))


def test_unity_dds_reads_with_openimageio_where_it_reads_dx10(bake_dir):
    out, _ = bake_dir
    oiiotool = shutil.which("oiiotool")
    if oiiotool is None:
        pytest.skip("oiiotool not installed")
    r = subprocess.run([oiiotool, "--info", "-v", str(out / "unity" / "specular.dds")], capture_output=True, text=True)
    if r.returncode != 0 and "Unsupported" in (r.stdout + r.stderr):
        pytest.skip("this OpenImageIO's DDS reader does not take DX10 float files: " + (r.stdout + r.stderr).strip())
    assert r.returncode == 0, r.stderr
    assert f"{FACE} x {FACE}" in r.stdout or f"{FACE}x{FACE}" in r.stdout


def test_cesium_ktx2_is_the_spec_chain_and_its_sh_is_filaments_form(bake_dir):
    """The worked example of a new preset (one row of the preset table):
    Cesium samples lod = r x maximum LOD, as SPEC's chain (so the levels are
    SPEC's, unmirrored), and evaluates sphericalHarmonicCoefficients as
    Filament's pre-scaled SH (czm_sphericalHarmonics), which the manifest gives."""
    out, res = bake_dir
    vk, scheme, n0, levels = ktx2_levels((out / "cesium" / "specular.ktx2").read_bytes())
    assert (vk, scheme, n0, len(levels)) == (97, 0, FACE, 6)
    for m, blob in enumerate(levels):
        n = max(1, FACE >> m)
        got = np.frombuffer(blob, np.float16).astype(np.float32).reshape(6, n, n, 4)
        np.testing.assert_array_equal(got[..., :3], cross_cube(out / f"specular_{m}.exr"))
    entry = res["manifest"]["presets"]["cesium"]
    assert sorted(entry["files"]) == ["specular"]  # the diffuse light is the SH, passed to Cesium's API
    k = np.array([0.282095, 0.325735, 0.325735, 0.325735, 0.273137, 0.273137, 0.078848, 0.273137, 0.136569])
    sh = np.array(entry["sh"]["coefficients"]).reshape(9, 3).T
    np.testing.assert_allclose(sh, res["sh9"] * k, rtol=1e-5, atol=1e-9)


def test_filament_ktx1_carries_the_prescaled_sh(bake_dir):
    out, res = bake_dir
    data = (out / "filament" / "ibl.ktx").read_bytes()
    assert data[:12] == b"\xabKTX 11\xbb\r\n\x1a\n"
    (endian, gl_type, type_size, gl_format, internal, base, w, h, d, arrays, faces, levels,
     kv_bytes) = struct.unpack_from("<13I", data, 12)
    assert (endian, gl_type, internal, faces, levels, w) == (0x04030201, 0x140B, 0x881A, 6, 2, FACE)
    size = struct.unpack_from("<I", data, 64)[0]
    key, value = data[68:68 + size].split(b"\0", 1)
    assert key == b"sh"
    sh = np.array([float(v) for v in value.split()]).reshape(9, 3).T
    k = np.array([0.282095, 0.325735, 0.325735, 0.325735, 0.273137, 0.273137, 0.078848, 0.273137, 0.136569])
    np.testing.assert_allclose(sh, res["sh9"] * k, rtol=1e-5, atol=1e-9)
    at = 64 + kv_bytes
    image_size = struct.unpack_from("<I", data, at)[0]
    assert image_size == FACE * FACE * 8
    level0 = np.frombuffer(data, np.float16, 6 * FACE * FACE * 4, at + 4).astype(np.float32).reshape(6, FACE, FACE, 4)
    np.testing.assert_array_equal(level0[..., :3], cross_cube(out / "specular_0.exr"))


def test_babylon_env_decodes_with_pillow(bake_dir):
    from PIL import Image
    import io
    out, res = bake_dir
    data = (out / "babylon" / "environment.env").read_bytes()
    assert data[:8] == bytes([0x86, 0x16, 0x87, 0x96, 0xF6, 0xD6, 0x96, 0x36])
    nul = data.index(b"\0", 8)
    info = json.loads(data[8:nul].decode("ascii"))
    assert info["version"] == 2 and info["width"] == FACE and info["specular"]["lodGenerationScale"] == 0.8
    levels = int(np.log2(FACE)) + 1
    assert len(info["specular"]["mipmaps"]) == 6 * levels
    base = nul + 1

    def level(m):
        faces = []
        for f in range(6):
            e = info["specular"]["mipmaps"][6 * m + f]
            png = Image.open(io.BytesIO(data[base + e["position"]:base + e["position"] + e["length"]]))
            assert png.mode == "RGBA"
            q = np.asarray(png, np.float64)[::-1] / 255.0  # stored bottom row first, as Babylon does
            faces.append(q[..., :3] ** 2.2 / q[..., 3:])  # Babylon's fromRGBD
        return np.stack(faces)

    rough = [l["roughness"] for l in res["manifest"]["presets"]["babylon"]["specular"]]
    assert rough[0] == 0.0 and rough[-1] == 1.0
    for m, spec in ((0, 0), (levels - 1, levels - 1)):  # r = 0 and the 1 x 1 at r = 1 are SPEC's levels too
        want = mirrored(cross_cube(out / f"specular_{spec}.exr"), "x").astype(np.float64)
        got = level(m)
        # RGBD: the largest channel to about 1 % above 1, 8-bit gamma below;
        # nothing above 255 (the bright spot is clamped there, and counted).
        inside = want.max(axis=-1) <= 255.0
        err = np.abs(got - want) / np.maximum(want.max(axis=-1, keepdims=True), 1.0)
        assert err[inside].max() < 0.02, (m, err[inside].max())
        assert np.allclose(got[~inside].max(axis=-1), 255.0, rtol=0.01)
    clamped = res["manifest"]["presets"]["babylon"]["written"][0]["clamped_texels"]
    assert clamped > 0
    # The polynomial is the SH9 irradiance of the x-mirrored radiance (Babylon's
    # glTF loader negates glTF's x) with bands 1 and 2 carrying A_l / pi once
    # more (Babylon evaluates them 3/2 and 4 times stronger).
    p = {k: np.array(v) for k, v in info["irradiance"].items()}
    n = np.array([1.0, 0.0, 0.0])  # engine +X sees what SPEC has at -X
    irr = p["x"] * n[0] + p["xx"] * n[0] ** 2
    sh = np.array(res["sh9"])
    y = np.array([0.282095, 0, 0, -0.488603, 0, 0, -0.315392, 0, 0.546274])  # SPEC basis at (-1, 0, 0)
    band = np.array([1, 2 / 3, 2 / 3, 2 / 3, .25, .25, .25, .25, .25])
    np.testing.assert_allclose(irr, (sh * band * band * y).sum(axis=1), rtol=1e-5)


def test_source_preset_keeps_the_lat_long(bake_dir):
    out, res = bake_dir
    back = ib.read_image(str(out / "source" / "source.exr"))
    np.testing.assert_array_equal(back, source())
    hdr = ib.read_image(str(out / "source" / "source.hdr"))  # OpenImageIO's Radiance reader
    assert hdr.shape == back.shape
    assert np.all(np.abs(hdr - back) <= back.max(axis=-1, keepdims=True) / 128 + 1e-6)


def test_presets_table_from_python():
    table = {p["name"]: p for p in ib.presets()}
    assert list(table) == ["three", "khronos", "bevy", "filament", "babylon", "unity", "cesium", "source"]
    assert table["three"]["mirror"] == "x" and table["three"]["curve"] == "filament"
    assert table["bevy"]["supercompression"] == "zstd" and table["bevy"]["format"] == "e5b9g9r9"
    np.testing.assert_allclose(table["unity"]["roughness_at_256"][:7],
                               [0, .102, .215, .342, .492, .681, 1], atol=5e-4)
    for p in table.values():
        assert p["description"] and p["container"] in ("ktx2", "dds", "ktx1", "env", "latlong")


def test_bad_presets_are_value_errors(tmp_path):
    img = source(64, 32)
    with pytest.raises(ValueError, match="unknown preset 'unreal'"):
        ib.bake(img, str(tmp_path / "a"), presets=["unreal"])
    with pytest.raises(ValueError, match="give an out_dir"):
        ib.bake(img, None, presets=["three"])
    with pytest.raises(ValueError, match="power-of-two"):
        ib.bake(img, str(tmp_path / "b"), presets=["babylon"], face_size=24)
    with pytest.raises(ValueError, match=r"presets must be a list of names \(e.g. \['three'\]\)"):
        ib.bake(img, str(tmp_path / "c"), presets="three")
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()


def test_layouts(tmp_path):
    img = source(64, 32)
    for layout, files in (("vcross", ["specular_0.exr"]), ("latlong", ["specular_0.exr"]),
                          ("faces", [f"specular_0_{f}.exr" for f in ("px", "nx", "py", "ny", "pz", "nz")])):
        out = tmp_path / layout
        res = ib.bake(img, str(out), face_size=8, irradiance_size=4, lut_size=16, layout=layout)
        m = res["manifest"]
        assert m["layout"] == layout
        assert m["specular"][0]["files"] == files and m["specular"][0]["file"] == files[0]
        for f in files:
            assert (out / f).is_file()
        a = ib.read_image(str(out / files[0]))
        assert a.shape[:2] == {"vcross": (32, 24), "latlong": (16, 32), "faces": (8, 8)}[layout]
        if layout == "faces":  # the +X face file is the cube's +X face
            np.testing.assert_array_equal(a, half(res["specular"][0][0]))


def test_cli_presets_listing_and_six_preset_bake(tmp_path):
    r = run("presets")
    assert r.returncode == 0
    for name in SIX + ["source"]:
        assert name in r.stdout
    assert run("--list-presets").stdout == r.stdout
    src = tmp_path / "src.exr"
    ib.bake(source(), None)  # the module works on this source
    # Write the source as EXR through a bake's own source preset.
    ib.bake(source(), str(tmp_path / "s"), presets=["source"], face_size=8, irradiance_size=4, lut_size=16)
    shutil.copy(tmp_path / "s" / "source" / "source.exr", src)
    out = tmp_path / "six"
    r = run("bake", str(src), "-o", str(out), "--face-size", "32", "--irradiance-size", "8", "--lut-size", "32",
            *[a for p in SIX for a in ("--preset", p)])
    assert r.returncode == 0, r.stderr
    m = json.loads((out / "manifest.json").read_text())
    assert sorted(m["presets"]) == sorted(SIX)
    for p in SIX:
        assert p in r.stdout  # one line per preset
    r = run("bake", str(src), "-o", str(tmp_path / "bad"), "--preset", "three,unreal")
    assert r.returncode == 1 and "unknown preset 'unreal'" in r.stderr and r.stderr.count("\n") == 1
    assert not (tmp_path / "bad").exists()


def test_manifest_hashes_every_file_it_lists(bake_dir):
    """The writer hashes files in the tasks that wrote them: every listed file
    exists, with the size and sha256 the manifest gives, and nothing written
    is left out."""
    import hashlib
    out, res = bake_dir
    files = json.loads((out / "manifest.json").read_text())["files"]
    on_disk = {p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file() and p.name != "manifest.json"}
    assert set(files) == on_disk
    assert any("/" in f for f in files)  # the presets' folders are in it
    for rel, entry in files.items():
        data = (out / rel).read_bytes()
        assert entry["bytes"] == len(data), rel
        assert entry["sha256"] == hashlib.sha256(data).hexdigest(), rel
