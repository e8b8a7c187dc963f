"""iblbake's own Radiance RGBE reader (native/src/io/hdr_file.cpp) against
another library's: OpenImageIO's, through oiiotool, which turns each .hdr
into a float EXR. Every value must be the same to the bit: files written by
OpenImageIO (run-length encoded, and flat below 8 pixels wide), by hand
(flat, mixed flat and run-length scanlines, long runs and literals, every
exponent, headers with comments, EXPOSURE and GAMMA lines), a file stored
turned (read whole through the plugin), and the errors of cut or damaged
files. The one exception: three exponents OpenImageIO scales one unit in
the last place low (OIIO_LOW_EXPONENTS); there iblbake's value is the exact
mantissa x 2^(exponent - 136)."""
import os
import shutil
import subprocess

import numpy as np
import pytest

import iblbake_core

pytestmark = pytest.mark.skipif(shutil.which("oiiotool") is None,
                                reason="needs oiiotool (openimageio-tools, scripts/install_deps.sh)")
FOREST = "/usr/share/blender/datafiles/studiolights/world/forest.exr"
# OpenImageIO (2.4, 2.5 and 3.1 alike) makes the scale 2^(e - 136) one unit
# in the last place low for these three exponents (values near 1e-28 and
# 1e28), where iblbake's reader keeps the exact product.
OIIO_LOW_EXPONENTS = (40, 223, 226)


def oiio_read(path, tmp_path, turn=False):
    """The file's pixels as OpenImageIO reads them (a float EXR in between)."""
    exr = str(tmp_path / (os.path.basename(path) + ".ref.exr"))
    subprocess.run(["oiiotool", *(["--autoorient"] if turn else []), path, "-d", "float", "-o", exr], check=True,
                   capture_output=True)
    return iblbake_core.read_image(exr)


def rle_component(values):
    """One component of a scanline in Radiance's runs: runs of 4 or more as
    (128 + n, v), the rest as literals (n, v0 .. vn-1), n <= 127."""
    out, i, n = bytearray(), 0, len(values)
    while i < n:
        j = i
        while j < n and j - i < 127 and values[j] == values[i]:
            j += 1
        if j - i >= 4:
            out += bytes([128 + j - i, values[i]])
            i = j
            continue
        k = i
        while k < n and k - i < 127 and not (k + 3 < n and values[k] == values[k + 1] == values[k + 2] == values[k + 3]):
            k += 1
        k = max(k, i + 1)
        out += bytes([k - i]) + bytes(values[i:k])
        i = k
    return bytes(out)


def write_rgbe(path, rgbe, header=b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n", rle_rows=(), resolution=None):
    """rgbe: (H, W, 4) uint8. Rows in rle_rows run-length encoded, the others flat."""
    h, w, _ = rgbe.shape
    out = bytearray(header + (resolution or ("-Y %d +X %d\n" % (h, w)).encode()))
    for y in range(h):
        if y in rle_rows:
            out += bytes([2, 2, w >> 8, w & 255])
            for c in range(4):
                out += rle_component(list(rgbe[y, :, c]))
        else:
            out += rgbe[y].tobytes()
    with open(path, "wb") as f:
        f.write(bytes(out))


def random_rgbe(h, w, seed):
    rng = np.random.default_rng(seed)
    rgbe = rng.integers(0, 256, size=(h, w, 4), dtype=np.uint8)
    rgbe[:, : w // 3] = rgbe[:, :1]  # runs
    rgbe[0, 0, 3], rgbe[0, 1, 3], rgbe[0, 2, 3] = 0, 1, 255  # zero, the smallest and the largest exponents
    return rgbe


def same(ours, theirs):
    assert ours.shape == theirs.shape and ours.dtype == theirs.dtype
    np.testing.assert_array_equal(ours.view(np.uint32), theirs.view(np.uint32))


@pytest.mark.parametrize("width,height", [(1024, 512), (8, 5), (7, 3), (1, 1)])
def test_files_openimageio_writes(tmp_path, width, height):
    hdr = str(tmp_path / ("w%d.hdr" % width))
    subprocess.run(["oiiotool", FOREST, "--resize", "%dx%d" % (width, height), "-o", hdr], check=True)
    same(iblbake_core.read_image(hdr), oiio_read(hdr, tmp_path))


def test_hand_written_flat_run_length_and_mixed_scanlines(tmp_path):
    rgbe = random_rgbe(9, 300, 1)
    cases = {
        "flat.hdr": {},
        "rle.hdr": {"rle_rows": range(9)},
        "mixed.hdr": {"rle_rows": (0, 2, 3, 8)},
        "header.hdr": {"rle_rows": (1,), "header": b"#?RGBE\n# made by hand\nEXPOSURE=4.0\nGAMMA=2.2\n"
                                                     b"SOFTWARE=test\nFORMAT=32-bit_rle_rgbe\n\n"},
        # OpenImageIO refuses these two: no '#?' line; Windows line ends in the header
        "nomagic.hdr": {"header": b"FORMAT=32-bit_rle_rgbe\n\n"},
        "crlf.hdr": {"header": b"#?RADIANCE\r\nFORMAT=32-bit_rle_rgbe\r\n\r\n", "rle_rows": (4,),
                     "resolution": b"-Y 9 +X 300\r\n"},
    }
    for name, kw in cases.items():
        path = str(tmp_path / name)
        write_rgbe(path, rgbe, **kw)
        ours = iblbake_core.read_image(path)
        m, e = rgbe[..., :3].astype(np.float64), rgbe[..., 3:].astype(np.int64)
        want = np.where(e == 0, 0.0, m * np.ldexp(1.0, e - 136)).astype(np.float32)  # EXPOSURE not applied
        np.testing.assert_array_equal(ours, want, err_msg=name)
        if name in ("nomagic.hdr", "crlf.hdr"):
            continue
        theirs = oiio_read(path, tmp_path)
        odd = np.isin(rgbe[..., 3], OIIO_LOW_EXPONENTS)[..., None].repeat(3, axis=2)
        same(np.where(odd, 0, ours).astype(np.float32), np.where(odd, 0, theirs).astype(np.float32))
        ulps = ours.view(np.int32).astype(np.int64) - theirs.view(np.int32).astype(np.int64)
        assert set(np.unique(ulps[odd])) <= {0, 1}, name


def test_a_file_stored_turned_is_read_whole_as_openimageio_turns_it(tmp_path):
    rgbe = random_rgbe(6, 10, 2)
    path = str(tmp_path / "turned.hdr")
    write_rgbe(path, rgbe, resolution=b"+Y 6 +X 10\n")  # rows bottom to top
    ours = iblbake_core.read_image(path)
    same(ours, oiio_read(path, tmp_path, turn=True))


def test_cut_and_damaged_files_fail_in_words(tmp_path):
    rgbe = random_rgbe(20, 64, 3)
    good = str(tmp_path / "good.hdr")
    write_rgbe(good, rgbe, rle_rows=range(20))
    data = open(good, "rb").read()
    cases = {
        "cut.hdr": (data[: len(data) * 2 // 3], "truncated"),
        "wide.hdr": (data.replace(b"\n\n-Y 20 +X 64\n\x02\x02\x00\x40", b"\n\n-Y 20 +X 64\n\x02\x02\x00\x41", 1),
                     "pixels wide"),
        "noformat.hdr": (b"#?RADIANCE\nEXPOSURE=1\n\n-Y 1 +X 1\n\x80\x80\x80\x80", "FORMAT"),
        "noresolution.hdr": (b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\nY 1 X 1\n\x80\x80\x80\x80", "resolution line"),
        "junk.hdr": (b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 1t\n\x80\x80\x80\x80", "resolution line"),
        "noheaderend.hdr": (b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n", "header"),
        "huge.hdr": (b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 16000 +X 32000\n\x80\x80\x80\x80", "declares"),
    }
    for name, (content, why) in cases.items():
        path = str(tmp_path / name)
        with open(path, "wb") as f:
            f.write(content)
        with pytest.raises(Exception) as e:
            iblbake_core.read_image(path)
        text = str(e.value)
        assert text.startswith("cannot read '%s': " % path) and why in text and "\n" not in text, (name, text)
    # a run past the scanline's end
    bad = bytearray(data)
    start = data.index(b"\x02\x02\x00\x40")
    bad[start + 4] = 128 + 100  # a run of 100 in a scanline of 64
    path = str(tmp_path / "run.hdr")
    with open(path, "wb") as f:
        f.write(bytes(bad))
    with pytest.raises(Exception, match="run past its end"):
        iblbake_core.read_image(path)
