"""The hostile-input corpus of issue 15, made by this script (nothing binary
is committed): truncations of every format, header fuzz with a fixed seed,
declared-size bombs, odd but legal files, files that are not files, output
folders that refuse a bake, and wrong arrays for the Python module.

  /usr/bin/python3 tests/hostile/corpus.py OUTDIR   # writes the input files (also the fuzzer's seeds)

tests/hostile/test_corpus.py runs every case and checks what issue 15 asks of
each; `cases()` lists them without touching the disk."""
import os
import random
import struct
import subprocess
import sys
import zlib
from dataclasses import dataclass, field
from typing import Callable, List, Optional

SEED = 15  # header fuzz and random bytes: the same corpus on every run
BASE_W, BASE_H = 64, 32


# --- EXR, written by hand: any header, any window, with or without chunks --------------------------

def _attr(name: str, type_: str, value: bytes) -> bytes:
    return name.encode() + b"\0" + type_.encode() + b"\0" + struct.pack("<i", len(value)) + value


def exr_bytes(width=BASE_W, height=BASE_H, channels=("B", "G", "R"), pixel_type=2, data_window=None,
              display_window=None, chunks=True, value=0.5, values=None, lines=None) -> bytes:
    """An uncompressed scanline EXR. data_window / display_window: (xmin, ymin, xmax, ymax),
    defaulting to the size given; chunks=False stops after the header (a size bomb);
    lines: how many scanline chunks to write (default: all); values: per-channel constants."""
    dw = data_window or (0, 0, width - 1, height - 1)
    disp = display_window or dw
    chlist = b"".join(c.encode() + b"\0" + struct.pack("<iB3xii", pixel_type, 0, 1, 1) for c in sorted(channels)) + b"\0"
    header = b"\x76\x2f\x31\x01" + struct.pack("<i", 2)
    header += _attr("channels", "chlist", chlist)
    header += _attr("compression", "compression", b"\0")
    header += _attr("dataWindow", "box2i", struct.pack("<4i", *dw))
    header += _attr("displayWindow", "box2i", struct.pack("<4i", *disp))
    header += _attr("lineOrder", "lineOrder", b"\0")
    header += _attr("pixelAspectRatio", "float", struct.pack("<f", 1.0))
    header += _attr("screenWindowCenter", "v2f", struct.pack("<2f", 0, 0))
    header += _attr("screenWindowWidth", "float", struct.pack("<f", 1.0))
    header += b"\0"
    if not chunks:
        return header
    w = dw[2] - dw[0] + 1
    h = dw[3] - dw[1] + 1
    n = h if lines is None else min(lines, h)
    size = 2 if pixel_type == 1 else 4
    vals = values or {c: value for c in channels}
    row = b""
    for c in sorted(channels):
        v = vals.get(c, value)
        if pixel_type == 1:
            row += struct.pack("<e", v) * w
        else:
            row += struct.pack("<f", v) * w
    table_size = 8 * h
    offset = len(header) + table_size
    table, body = b"", b""
    for i in range(h):
        table += struct.pack("<Q", offset + len(body) if i < n else 0)
        if i < n:
            body += struct.pack("<ii", dw[1] + i, len(row)) + row
    assert len(row) == w * size * len(channels)
    return header + table + body


# --- PNG, by hand: a header that says anything -------------------------------------------------------

def _png_chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)


def png_bytes(width, height, rows: Optional[int] = None, depth=8, colour=2) -> bytes:
    """An RGB PNG declaring width x height; rows (default all, capped at 64) of grey data follow."""
    ihdr = struct.pack(">IIBBBBB", width, height, depth, colour, 0, 0, 0)
    channels = {0: 1, 2: 3, 4: 2, 6: 4}[colour]
    n = min(height, 64) if rows is None else rows
    raw = b"".join(b"\0" + bytes([128]) * (width * channels * depth // 8) for _ in range(n)) if width <= 4096 else b""
    return (b"\x89PNG\r\n\x1a\n" + _png_chunk(b"IHDR", ihdr) + _png_chunk(b"IDAT", zlib.compress(raw)) +
            _png_chunk(b"IEND", b""))


def hdr_bytes(width, height, rows=None) -> bytes:
    """A Radiance HDR declaring width x height, flat (not RLE) pixels, `rows` of them."""
    head = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y %d +X %d\n" % (height, width)
    n = height if rows is None else rows
    return head + bytes([128, 128, 128, 129]) * (width * n if width * n < 1 << 22 else 16)


# --- issue 24: files that look right but aren't -------------------------------------------------------

def _combined(prefix="ViewLayer.Combined.", rgba=(0.9, 0.3, 0.05, 1.0)):
    return {prefix + c: v for c, v in zip("RGBA", rgba)}


def _exr_of(values):
    return lambda: exr_bytes(channels=tuple(values), values=values)


# name -> bytes of a single-part EXR; the first three must bake orange (0.9, 0.3, 0.05), the rest be refused.
LOOKS_RIGHT_EXR = {
    # Blender's OpenEXR MultiLayer: Combined plus passes whose names sort before it.
    "blender_multilayer": _exr_of({**_combined(), "ViewLayer.AO.R": 0.1, "ViewLayer.AO.G": 0.1, "ViewLayer.AO.B": 0.1,
                                   "ViewLayer.Depth.Z": 1000.0}),
    "layer_diffuse": _exr_of({"diffuse.R": 0.9, "diffuse.G": 0.3, "diffuse.B": 0.05}),
    "lowercase_rgb": _exr_of({"r": 0.9, "g": 0.3, "b": 0.05}),
    "alpha_only": _exr_of({"A": 1.0}),
    "depth_only": _exr_of({"Z": 1000.0}),
    "aov_only": _exr_of({"ViewLayer.MyAOV.V": 0.7}),
    "z_and_depth": _exr_of({"Z": 1000.0, "depth.V": 3.0}),
    "two_layers": _exr_of({**_combined("diffuse."), **_combined("specular.", (0.1, 0.1, 0.1, 1.0))}),
}
LOOKS_RIGHT_OK = {"blender_multilayer", "layer_diffuse", "lowercase_rgb"}


def make_multipart_depth_first(path):
    """Two parts: a depth pass (Z = 1000) first, the orange colour second."""
    subprocess.run(["oiiotool", "--pattern", "constant:color=1000", "%dx%d" % (BASE_W, BASE_H), "1", "--chnames", "Z",
                    "-d", "float", "--pattern", "constant:color=0.9,0.3,0.05", "%dx%d" % (BASE_W, BASE_H), "3",
                    "-d", "float", "--siappend", "-o", path], check=True, capture_output=True)


def exr_subsampled_bytes():
    """An EXR whose channels are sampled every 2 x 2 pixels (the chlist's sampling fields)."""
    d = exr_bytes()
    i = d.index(b"channels\0chlist\0") + len(b"channels\0chlist\0") + 4
    for c in (b"B", b"G", b"R"):
        j = d.index(c + b"\0", i) + 2
        d = d[:j + 8] + struct.pack("<ii", 2, 2) + d[j + 16:]
    return d


def make_deep_exr(path):
    subprocess.run(["oiiotool", "--create", "%dx%d" % (BASE_W, BASE_H), "4", "--chnames", "R,G,B,Z", "-d", "float",
                    "--deepen", "-o", path], check=True, capture_output=True)


def make_gradient_exr(path, width, height):
    with open(path, "wb") as f:
        f.write(exr_bytes(width, height, value=0.5))


# Radiance HDR resolution strings (H, W replaced by the sizes); each file shows the same image.
HDR_ORIENTATIONS = {"flipped_y": "+Y H +X W", "mirrored_x": "-Y H -X W", "rotated_180": "+Y H -X W",
                    "transposed": "+X W +Y H", "columns_top_down": "+X W -Y H", "columns_right_left": "-X W -Y H"}


def hdr_oriented(resolution, width=BASE_W, height=BASE_H):
    """A flat RGBE file whose displayed image is the gradient below, stored in `resolution`'s order."""
    def texel(x, y):
        return bytes([(x * 4 + 8) % 256, (y * 8 + 8) % 256, 100 + (x * y) % 100, 128])
    first, second = resolution.split()[0:2], resolution.split()[2:4]
    axes = {first[0][1]: first[0][0], second[0][1]: second[0][0]}  # axis -> sign
    n = {"X": width, "Y": height}

    def coords(axis, k):  # Radiance's +Y runs bottom to top; -X right to left
        if axis == "Y":
            return height - 1 - k if axes["Y"] == "+" else k
        return width - 1 - k if axes["X"] == "-" else k
    outer, inner = first[0][1], second[0][1]
    body = bytearray()
    for i in range(n[outer]):
        for j in range(n[inner]):
            x = coords("X", i if outer == "X" else j)
            y = coords("Y", i if outer == "Y" else j)
            body += texel(x, y)
    res = resolution.replace("H", str(height)).replace("W", str(width))
    return b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n" + res.encode() + b"\n" + bytes(body)


def make_oriented_tiff(path, orientation):
    """A float TIFF with EXIF Orientation `orientation`, stored 32 x 64 where that turns it (5 to 8)."""
    size = "%dx%d" % ((BASE_H, BASE_W) if orientation >= 5 else (BASE_W, BASE_H))
    subprocess.run(["oiiotool", "--pattern", "fill:topleft=0.1,0.2,0.4:topright=2,1.5,1:bottomleft=0.05,0.1,0.02:"
                    "bottomright=0.3,0.2,0.1", size, "3", "-d", "float", "--orientation", str(orientation),
                    "-o", path], check=True, capture_output=True)


ALPHA_PNG_RGBA = (200, 100, 50, 128)
# What Cycles renders for it (measured with Blender 3.4's Cycles): the stored colour times alpha, then decoded.
ALPHA_PNG_RADIANCE = [((c * ALPHA_PNG_RGBA[3] / 255 / 255 + 0.055) / 1.055) ** 2.4 for c in ALPHA_PNG_RGBA[:3]]


def make_alpha_png(path):
    """An 8-bit sRGB RGBA PNG with straight alpha 128 over a constant colour (Cycles shows colour x alpha)."""
    ihdr = struct.pack(">IIBBBBB", BASE_W, BASE_H, 8, 6, 0, 0, 0)
    raw = b"".join(b"\0" + bytes(ALPHA_PNG_RGBA) * BASE_W for _ in range(BASE_H))
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + _png_chunk(b"IHDR", ihdr) + _png_chunk(b"IDAT", zlib.compress(raw)) +
                _png_chunk(b"IEND", b""))


def make_alpha_tif(path):
    """The same colour as make_alpha_png as an 8-bit RGBA TIFF with associated alpha (ExtraSamples 1), its
    colour multiplied by alpha in the stored values as OpenImageIO 2.4 writes it. Written here, not by
    oiiotool: 2.5 multiplies in linear light (147, 72, 34 instead of 100, 50, 25), so the file's colour
    would depend on the host's version."""
    px = bytes([round(c * ALPHA_PNG_RGBA[3] / 255) for c in ALPHA_PNG_RGBA[:3]] + [ALPHA_PNG_RGBA[3]])
    data = px * (BASE_W * BASE_H)
    entries = [(256, 4, 1, BASE_W), (257, 4, 1, BASE_H), (258, 3, 4, None), (259, 3, 1, 1), (262, 3, 1, 2),
               (273, 4, 1, None), (277, 3, 1, 4), (278, 4, 1, BASE_H), (279, 4, 1, len(data)), (284, 3, 1, 1),
               (338, 3, 1, 1)]
    ifd_at = 8
    bits_at = ifd_at + 2 + 12 * len(entries) + 4
    data_at = bits_at + 8
    ifd = struct.pack("<H", len(entries))
    for tag, typ, n, value in entries:
        if tag == 258:
            ifd += struct.pack("<HHII", tag, typ, n, bits_at)
        elif typ == 3:
            ifd += struct.pack("<HHIHH", tag, typ, n, data_at if tag == 273 else value, 0)
        else:
            ifd += struct.pack("<HHII", tag, typ, n, data_at if tag == 273 else value)
    with open(path, "wb") as f:
        f.write(b"II*\0" + struct.pack("<I", ifd_at) + ifd + struct.pack("<I", 0) + struct.pack("<4H", 8, 8, 8, 8) +
                data)


# --- sources made by OpenImageIO (oiiotool), then cut and fuzzed ---------------------------------------

GOOD = {
    # name: oiiotool arguments after the generated pattern
    "half_zip.exr": ["-d", "half", "--compression", "zip"],
    "float_piz.exr": ["-d", "float", "--compression", "piz"],
    "half_rle.exr": ["-d", "half", "--compression", "rle"],
    "half_tiled.exr": ["-d", "half", "--tile", "16", "16"],
    "rgb8.png": ["-d", "uint8"],
    "rgb16.png": ["-d", "uint16"],
    "rgb.jpg": ["-d", "uint8"],
    "rgb.hdr": [],
    "float.tif": ["-d", "float"],
    "rgb8.tga": ["-d", "uint8"],
    "rgb8.bmp": ["-d", "uint8"],
}


GOOD_BYTES = {}  # name -> bytes of the good file, made once per process


def good_bytes(name: str) -> bytes:
    if name not in GOOD_BYTES:
        import tempfile
        with tempfile.TemporaryDirectory() as d:
            p = os.path.join(d, name)
            _oiiotool(p, name)
            with open(p, "rb") as f:
                GOOD_BYTES[name] = f.read()
    return GOOD_BYTES[name]


def make_good(path: str, name: str):
    with open(path, "wb") as f:
        f.write(good_bytes(name))


def _oiiotool(path: str, name: str):
    args = GOOD[name]
    subprocess.run(["oiiotool", "--pattern", "fill:topleft=0.1,0.2,0.4:topright=2,1.5,1:bottomleft=0.05,0.1,0.02:"
                    "bottomright=0.3,0.2,0.1", "%dx%d" % (BASE_W, BASE_H), "3", *args, "-o", path],
                   check=True, capture_output=True)


@dataclass
class Case:
    name: str                      # unique, also the file name of the input where there is one
    kind: str                      # truncation, fuzz, bomb, odd, notafile, output, array
    make: Optional[Callable[[str], None]] = None  # writes the input file at the given path
    expect: str = "any"            # "error": must fail; "ok": must bake; "any": either, checked
    reference: Optional[str] = None  # a truncation that bakes must bake like this good file
    mean: Optional[List[float]] = None  # issue 24: the mean radiance a bake must have (a wrong result otherwise)
    same_as: Optional[Callable[[str], None]] = None  # issue 24: writes a file whose bake's sh9 it must match
    note: str = ""
    args: List[str] = field(default_factory=list)  # extra CLI arguments


def _write(data: bytes):
    def make(path):
        with open(path, "wb") as f:
            f.write(data)
    return make


def _cut(name: str, size: int):
    def make(path):
        data = good_bytes(name)
        with open(path, "wb") as f:
            f.write(data[:size] if size >= 0 else data[:len(data) + size])
    return make


def _mutate(name: str, seed: int, span: int, fix_png_crc: bool = False):
    """Flips 1 to 4 bytes (or writes 0xFF runs) in the first `span` bytes."""
    def make(path):
        data = bytearray(good_bytes(name))
        rng = random.Random(seed)
        for _ in range(rng.randint(1, 4)):
            i = rng.randrange(min(span, len(data)))
            how = rng.random()
            if how < 0.5:
                data[i] ^= 1 << rng.randrange(8)
            elif how < 0.8:
                data[i] = rng.choice([0x00, 0xFF, 0x7F, 0x80, rng.randrange(256)])
            else:
                for k in range(i, min(i + rng.randint(2, 8), len(data))):
                    data[k] = 0xFF
        if fix_png_crc and data[12:16] == b"IHDR":
            data[29:33] = struct.pack(">I", zlib.crc32(bytes(data[12:29])) & 0xFFFFFFFF)
        with open(path, "wb") as f:
            f.write(bytes(data))
    return make


def _random_bytes(n: int, seed: int):
    rng = random.Random(seed)
    return _write(bytes(rng.randrange(256) for _ in range(n)))


def _zeros(n: int):
    def make(path):
        with open(path, "wb") as f:
            f.truncate(n)
    return make


TRUNCATE_AT = [1, 2, 4, 8, 16, 33, 64, 100, 200, 400, 800]
TRUNCATE_FRACTIONS = [0.1, 0.25, 0.5, 0.75, 0.9, 0.99]


def good_size(name: str) -> int:
    return len(good_bytes(name))


def cases() -> List[Case]:
    out: List[Case] = []
    # Good files: every format bakes (a negative control for everything below).
    for name in GOOD:
        out.append(Case("good_" + name, "good", lambda p, n=name: make_good(p, n), expect="ok"))
    # Truncations of every format: at fixed sizes and fractions; a cut file that still bakes
    # must bake what the whole file does (nothing silently filled).
    for name in GOOD:
        n = good_size(name)
        sizes = sorted({s for s in TRUNCATE_AT if s < n} | {int(n * f) for f in TRUNCATE_FRACTIONS} | {n - 1})
        ext = os.path.splitext(name)[1]
        for s in sizes:
            out.append(Case("cut_%s_%d%s" % (name.replace(".", "_"), s, ext), "truncation", _cut(name, s),
                            reference="good_" + name))
    # Header fuzz, fixed seed.
    fuzz_plan = [("half_zip.exr", 120, 400, False), ("float_piz.exr", 30, 400, False), ("rgb8.png", 30, 64, False),
                 ("rgb8.png", 30, 33, True), ("rgb.jpg", 40, 300, False), ("rgb.hdr", 30, 80, False),
                 ("float.tif", 30, 300, False), ("rgb8.tga", 15, 18, False), ("rgb8.bmp", 15, 54, False)]
    for name, count, span, fix in fuzz_plan:
        ext = os.path.splitext(name)[1]
        for k in range(count):
            seed = SEED * 100000 + hash_name(name) * 1000 + k + (500 if fix else 0)
            out.append(Case("fuzz_%s_%s%d%s" % (name.replace(".", "_"), "crc_" if fix else "", k, ext), "fuzz",
                            _mutate(name, seed, span, fix)))
    # Declared-size bombs: small files whose headers ask for gigabytes.
    bombs = {
        "bomb_exr_40000x20000.exr": exr_bytes(data_window=(0, 0, 39999, 19999), chunks=False),
        "bomb_exr_30000x16000_header_only.exr": exr_bytes(data_window=(0, 0, 29999, 15999), chunks=False),
        "bomb_exr_30000x16000_one_line.exr": exr_bytes(data_window=(0, 0, 29999, 15999), lines=1),
        "bomb_exr_display_24576x12288.exr": exr_bytes(display_window=(0, 0, 24575, 12287)),
        "bomb_exr_display_40000x20000.exr": exr_bytes(display_window=(0, 0, 39999, 19999)),
        "bomb_exr_display_overflow.exr": exr_bytes(display_window=(-2**31, -2**31, 2**31 - 1, 2**31 - 1)),
        "bomb_exr_data_overflow.exr": exr_bytes(data_window=(-2**31 + 1, 0, 2**31 - 2, 0), chunks=False),
        "bomb_exr_inverted_window.exr": exr_bytes(data_window=(10, 10, 0, 0), chunks=False),
        "bomb_exr_1x65536.exr": exr_bytes(data_window=(0, 0, 0, 65535), chunks=False),
        "bomb_exr_65537x1.exr": exr_bytes(data_window=(0, 0, 65536, 0), chunks=False),
        "bomb_exr_missing_lines.exr": exr_bytes(lines=5),
        # Found by scripts/fuzz.sh: OpenEXR 3.1 allocated an attribute's declared 1.9 GB before reading it.
        "bomb_exr_attribute_1.9GB.exr": exr_bytes()[:8] + b"capDate\0string\0" + struct.pack("<i", 1936286739) + b"x" * 700,
        "bomb_png_40000x20000.png": png_bytes(40000, 20000),
        "bomb_png_30000x16000.png": png_bytes(30000, 16000),
        "bomb_png_2147483647x1.png": png_bytes(2**31 - 1, 1),
        "bomb_png_0x0.png": png_bytes(0, 0),
        "bomb_png_missing_rows.png": png_bytes(64, 32, rows=4),
        "bomb_hdr_40000x20000.hdr": hdr_bytes(40000, 20000, rows=0),
        "bomb_hdr_30000x16000.hdr": hdr_bytes(30000, 16000, rows=0),
        "bomb_hdr_missing_rows.hdr": hdr_bytes(64, 32, rows=3),
    }
    for name, data in bombs.items():
        out.append(Case(name, "bomb", _write(data), expect="error" if "display" not in name else "any"))
    out.append(Case("bomb_jpeg_65535x65535.jpg", "bomb", _jpeg_sof(65535, 65535), expect="error"))
    # Found by scripts/fuzz.sh: OpenImageIO 2.4's JPEG reader read past its buffer in decode_iptc_iim
    # (AddressSanitizer); JPEG is now read with libjpeg directly. The input, as the fuzzer saved it.
    import base64
    out.append(Case("fuzz_found_iptc_overread.jpg", "fuzz", _write(base64.b64decode(FUZZ_IPTC_OVERREAD))))
    # Odd but legal: sizes from 1 x 1, channel layouts, bad values (counted repairs).
    odd = {
        "odd_1x1.exr": exr_bytes(1, 1),
        "odd_2x1.exr": exr_bytes(2, 1),
        "odd_1x2.exr": exr_bytes(1, 2),
        "odd_3x1000.exr": exr_bytes(3, 1000),
        "odd_4096x1.exr": exr_bytes(4096, 1),
        "odd_grey_Y.exr": exr_bytes(channels=("Y",)),
        "odd_two_channels_RG.exr": exr_bytes(channels=("R", "G")),
        "odd_rgba.exr": exr_bytes(channels=("R", "G", "B", "A")),
        "odd_alpha_only.exr": exr_bytes(channels=("A",)),
        "odd_foreign_channels.exr": exr_bytes(channels=("Z", "depth.V")),
        "odd_nan.exr": exr_bytes(value=float("nan")),
        "odd_inf.exr": exr_bytes(value=float("inf")),
        "odd_negative.exr": exr_bytes(value=-1.0),
        "odd_huge.exr": exr_bytes(value=3.0e38),
        "odd_subnormal.exr": exr_bytes(value=1e-42),
        "odd_mixed_bad.exr": exr_bytes(values={"R": float("nan"), "G": float("-inf"), "B": -2.0}),
        "odd_half.exr": exr_bytes(pixel_type=1, value=60000.0),
        "odd_data_window_inside.exr": exr_bytes(data_window=(8, 4, 55, 27), display_window=(0, 0, 63, 31)),
        "odd_data_window_outside.exr": exr_bytes(data_window=(100, 100, 163, 131), display_window=(0, 0, 63, 31)),
        "odd_negative_origin.exr": exr_bytes(data_window=(-64, -32, -1, -1), display_window=(-64, -32, -1, -1)),
        "odd_square.exr": exr_bytes(32, 32),
        "odd_png_grey_alpha16.png": png_bytes(64, 32, depth=16, colour=4),
        "odd_png_grey.png": png_bytes(64, 32, colour=0),
        "odd_png_rgba.png": png_bytes(64, 32, colour=6),
        "odd_hdr_flat.hdr": hdr_bytes(64, 32),
    }
    for name, data in odd.items():
        out.append(Case(name, "odd", _write(data),
                        expect="error" if name in ("odd_foreign_channels.exr", "odd_alpha_only.exr") else "ok"))
    out += issue24_cases()
    # Things that are not image files.
    out += [
        Case("notafile_empty.exr", "notafile", _write(b""), expect="error"),
        Case("notafile_text.png", "notafile", _write(b"hello, these are my notes\n" * 20), expect="error"),
        Case("notafile_text.exr", "notafile", _write(b"not an exr\n" * 20), expect="error"),
        Case("notafile_random.hdr", "notafile", _random_bytes(4096, SEED), expect="error"),
        Case("notafile_random.noext", "notafile", _random_bytes(4096, SEED + 1), expect="error"),
        Case("notafile_zeros_64MB.exr", "notafile", _zeros(64 << 20), expect="error"),
        Case("notafile_zeros.jpg", "notafile", _zeros(1 << 20), expect="error"),
        Case("notafile_blend.png", "notafile", _write(b"BLENDER-v300" + bytes(2000)), expect="error"),
        Case("special_fifo.exr", "notafile", None, expect="error"),
        Case("special_dev_zero", "notafile", None, expect="error"),
        Case("special_dev_urandom", "notafile", None, expect="error"),
        Case("special_dev_null", "notafile", None, expect="error"),
        Case("special_directory.exr", "notafile", None, expect="error"),
        Case("special_dangling_link.exr", "notafile", None, expect="error"),
        Case("special_link_to_good.exr", "notafile", None, expect="ok"),
        Case("special_missing.exr", "notafile", None, expect="error"),
    ]
    # Output folders.
    for name in ["out_read_only", "out_parent_read_only", "out_full_disk", "out_is_a_file", "out_dangling_link",
                 "out_link_to_bake", "out_not_a_bake", "out_bake_with_users_file", "out_name_250",
                 "out_name_256", "out_deep_new_parent", "out_holds_source", "out_current_folder", "out_root",
                 "out_damaged_manifest", "out_read_only_file_system"]:
        out.append(Case(name, "output", None,
                        expect="ok" if name in ("out_link_to_bake", "out_name_250", "out_deep_new_parent") else "error"))
    # Bad options (the CLI's one-line usage errors).
    for args in (["--face-size", "0"], ["--face-size", "100000"], ["--mips", "100"], ["--lut-size", "-3"],
                 ["--eps", "nan"], ["--eps", "inf"], ["--exposure", "nan"], ["--rgbm-range", "0"],
                 ["--threads", "-1"], ["--hot-threshold", "nan"], ["--format", "tiff"], ["--lut-model", "x"],
                 ["--samples", "0", "--specular-method", "fis"], ["--face-size", "abc"], ["--bogus"],
                 ["--max-hot", "-1"], ["--irradiance-size", "99999999999"],
                 # issue 24: contradictory or empty presets, and presets that would hold the mirror level alone
                 ["--preset", "khronos:rgba32f:rgba16f"], ["--preset", "khronos:zstd:nozstd"], ["--preset", "khronos:"],
                 ["--preset", ""], ["--preset", "three,,khronos"], ["--preset", "three"], ["--preset", "filament"]):
        out.append(Case("opt_" + "_".join(a.strip("-") for a in args).replace(":", "_").replace(",", "_") or "empty",
                        "option", None, expect="error", args=args))
    # Wrong arrays for iblbake_core.bake().
    for name in ARRAYS:
        out.append(Case("array_" + name, "array", None, expect="ok" if name in ARRAYS_OK else "error"))
    names = [c.name for c in out]
    assert len(names) == len(set(names)), "duplicate case names"
    return out


ORANGE = [0.9, 0.3, 0.05]


def _oiiotool_from(make_source, *args):
    """A file made by oiiotool from the file `make_source` writes (a conversion; `args` before the input
    (--iconfig) and after it)."""
    def make(path):
        tmp = path + ".src.png"
        make_source(tmp)
        pre = list(args[:3]) if args[:1] == ("--iconfig",) else []
        subprocess.run(["oiiotool", *pre, tmp, *args[len(pre):], "-o", path], check=True, capture_output=True)
        os.remove(tmp)
    return make


# EXIF's orientations as pixel operations on the stored image (ImageMagick's -auto-orient does the same;
# OpenImageIO 2.4's --reorient swaps 5 and 7).
EXIF_TURNS = {1: [], 2: ["--flop"], 3: ["--rotate180"], 4: ["--flip"], 5: ["--transpose"], 6: ["--rotate90"],
              7: ["--transpose", "--rotate180"], 8: ["--rotate270"]}


def reoriented_tiff(path, orientation):
    """The image make_oriented_tiff(…, orientation) shows, as a float EXR without orientation."""
    tmp = path + ".tif"
    make_oriented_tiff(tmp, orientation)
    subprocess.run(["oiiotool", tmp, *EXIF_TURNS[orientation], "-d", "float", "-o", path], check=True,
                   capture_output=True)
    os.remove(tmp)


def _reoriented(orientation):
    return lambda path: reoriented_tiff(path, orientation)


def issue24_cases() -> List[Case]:
    """Issue 24's families: files that look right but aren't (layer names,
    multi-part, orientation, alpha, colour spaces), cache entries renamed,
    truncated or replaced by FIFOs, output folders changed during a bake,
    and Blender worlds with UDIM, sequences and missing images."""
    out: List[Case] = []
    for name, data in LOOKS_RIGHT_EXR.items():
        ok = name in LOOKS_RIGHT_OK
        out.append(Case("looks_%s.exr" % name, "looks_right", lambda p, d=data: _write(d())(p),
                        expect="ok" if ok else "error", mean=ORANGE if ok else None))
    out.append(Case("looks_multipart_depth_first.exr", "looks_right", make_multipart_depth_first, expect="ok",
                    mean=ORANGE))
    out.append(Case("looks_luminance_only.exr", "looks_right", _write(exr_bytes(channels=("Y",), value=0.5)),
                    expect="ok", mean=[0.5, 0.5, 0.5]))
    for name, res in sorted(HDR_ORIENTATIONS.items()):
        out.append(Case("looks_hdr_%s.hdr" % name, "looks_right", _write(hdr_oriented(res)), expect="ok",
                        same_as=_write(hdr_oriented("-Y H +X W"))))
    for o in range(1, 9):
        out.append(Case("looks_tiff_orientation_%d.tif" % o, "looks_right", lambda p, o=o: make_oriented_tiff(p, o),
                        expect="ok", same_as=_reoriented(o)))
    out.append(Case("looks_alpha_straight.png", "looks_right", make_alpha_png, expect="ok", mean=ALPHA_PNG_RADIANCE))
    # Converted by oiiotool: Targa reading the PNG's alpha as stored (straight), as Targa keeps it; TIFF
    # through OpenImageIO's own premultiplied path (it writes associated alpha). (OpenImageIO 2.4's WebP
    # writer changes the colour under alpha, so no WebP is made here.)
    out.append(Case("looks_alpha_from_png.tga", "looks_right",
                    _oiiotool_from(make_alpha_png, "--iconfig", "oiio:UnassociatedAlpha", "1"), expect="ok",
                    mean=ALPHA_PNG_RADIANCE))
    out.append(Case("looks_alpha_associated.tif", "looks_right", make_alpha_tif, expect="ok",
                    mean=ALPHA_PNG_RADIANCE))
    out.append(Case("looks_alpha_premultiplied.exr", "looks_right",
                    _write(exr_bytes(channels=("R", "G", "B", "A"), values={"R": 0.45, "G": 0.15, "B": 0.025,
                                                                           "A": 0.5})),
                    expect="ok", mean=[0.45, 0.15, 0.025]))
    out.append(Case("looks_xyze.hdr", "looks_right",
                    _write(hdr_bytes(BASE_W, BASE_H).replace(b"32-bit_rle_rgbe", b"32-bit_rle_xyze")), expect="error"))
    out.append(Case("looks_subsampled.exr", "looks_right", _write(exr_subsampled_bytes()), expect="error"))
    out.append(Case("looks_deep.exr", "looks_right", make_deep_exr, expect="error"))
    out.append(Case("looks_dds_export.dds", "looks_right", _write(b"DDS " + struct.pack("<I", 124) + bytes(200)),
                    expect="error"))
    out.append(Case("looks_huge_for_rgbe.exr", "looks_right", _write(exr_bytes(value=3.0e38)), expect="ok",
                    args=["--preset", "source"]))
    for name in CACHE_CASES:
        out.append(Case("cache_" + name, "cache", None, expect="ok"))
    for name in DURING_CASES:
        out.append(Case("during_" + name, "during", None, expect="ok" if name in DURING_OK else "error"))
    for name in BLENDER_WORLDS:
        out.append(Case("blender_" + name, "blender", None, expect="error" if name != "srgb_float" else "ok"))
    return out


# Cache entries after a good bake: how each is damaged (the bake must give the same files as without the cache).
CACHE_CASES = ["lut_models_swapped", "enc_exr_png_swapped", "lut_truncated", "enc_truncated", "lut_fifo",
               "enc_fifo", "lut_symlink", "lut_directory", "lut_renamed_from_other_size"]
# The output folder while a bake runs: what happens to it once the staging folder exists.
DURING_CASES = ["file_added_to_earlier_bake", "folder_made_at_path", "empty_folder_made_at_path",
                "locked_staging_of_other_namespace", "earlier_bake_removed"]
DURING_OK = {"empty_folder_made_at_path", "locked_staging_of_other_namespace", "earlier_bake_removed"}
# tests/blender/cases.py's save_hostile_world kinds, baked by bake_world.py (Blender only).
BLENDER_WORLDS = ["udim", "udim_1001", "sequence_gap", "mix_missing", "srgb_float"]


FUZZ_IPTC_OVERREAD = (
    '/9j/4AAQSkZJRgAB//////8BAAD/4QGwRXhpZgAASUkqAFQBAABvaWlvdG9vbCAtLXBhaHRlcm4gZmlsbDp0b3BsZWZ0PTAuMSww'
    'LjIsMC40OnRvcHJpZ2h0PTIsMS41LDE6Ym90dG9tbGVmdD0wLjA1LDAuMSwwLjAyOmJvdHRvbXJpZ2h0PTAuMywwLjIsMC4xIDY0'
    '+DMyIDMgLWQgdWluZDggLW8gL3RtcC90bXBsOGoyejc0YS9yZ2IuanBnAE9wZW5JbWFnZUlPIDIuNC43LjEgOiBvaWlvdG9vbCAt'
    'LXBhdHRlcm4gZmlsbDp0b3BsZWZ0PTAuMSwwLjIsMC40OnRvcHJpZ2h0PTIsMS41LDE6Ym90dG9tbGVmdD0wLjA1LDAuMSwwLjAy'
    'OmJvdHRvbXJpZ2h0PTAuMywwLjIsMC4xIDY0eDMyIDMgLWQgdWludDggLW8gL3RtcC90bXBsOGoyejc0YS9yZ2IuanBnAAIAMQEC'
    'ALEAAACjAAAAaYcEAAEAAAByAQAAAAAAAAQAAJAHAAQAAAAwMjMwAZEHAAQAAAABAgMAE5ICAJsAAAAIAAAAAKAHAAQAAAAwMTAw'
    'AAAAAP/tACxQaG90b3Nob3AgMy4wADhCSU0EBAAAAAAAtRwCQQCwT3BlbkltYWdlSU8gMi40LjcuMSA6IG9paW90b29sIC0tcGF0'
    'dGVybiBmaWxsOnRvcGxlZnQ9MC4xLDAuMiwwLjQ6dG9wcmlnaHQ9MiwxLjUsMTpib3R0b21sZWZ0PTAuMDUsMC4xLDAuMDI6Ym90'
    'dG9tcmlnaHQ9MC4zLDAuMiwwLjEgNjR4MzIgMyAtZCB1aW50OCAtbyAvdG1wL3RtcGw4ajJ6NzRhL3JnYi5qcGf/2wBDAAEBAQEB'
    'AQEBAQEBAQEBAQIBAQEBAQIBAQECAgICAgICAgIDAwQDAwMDAwIEAwIDBAMEBAQEAgMFBQQEBQQEBAT/2wBDAQEBAQEBAQIBAQIE'
    'AwIDBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAQEBAT/wAARCAAgAEADASIAAhEBAxEB/8QA'
    'HwAAAQUBAQEBAQEAAAAAAAAAAAECAwQFBgcICQoL/8QAtRAAAgEDAwIEAwUFBAQAAAF9AQIDAAQRBRIhMUEGE1FhByJxFDKBkaEI'
    'I0KxwRVS0fAkM2JyggkKFhcYGRolJicoKSo0NTY3ODk6Q0RFRkdISUpTVFVWV1hZWmNkZWZnaGlqc3R1dnd4eXqDhIWGh4iJipKT'
    'lJWWl5iZmqKjpKWmp6ipqrKztLW2t7i5usLDxMXGx8jJytLT1NXW19jZ2uHi4+Tl5ufo6erx8vP09fb3+Pn6/8QAHwEAAwEBAQEB'
    'AQEBAQAAAAAAAAECAwQFBgcICQoL/8QAtREAAgECBAQDBAcFBAQAAQJ3AAECAxEEBSExBhJBUQdhcRMiMoEIFEKRobHB8FIjMwkV'
    'YnLRChYkNOEl8RcYGRomJygpKjU2Nzg5OkNERUZHSElKU1RVVldYWVpjZGVmZ2hpanN0dXZ3eHl6goOEhYaHiImKkpOUlZaXmJma'
    'oqOkpaanqKmqsrO0tba3uLm6wsPExcbHyCfJytLT1NXW19jZ2uLj5OXm5+jp6vLz9PX29/j5+v/aAAwDAQACEQMRAD8A/n8+EWue'
    'R9l+fGMEc6N+zSJ88afZ/sv73GABjdxX4r/DrXBB5B34xg46ECvvL4deNPI+z/vcdP4sAV+oca579Z5/ePleFafseU/fv4R/EzyP'
    'sv8ApGMYP3q/Ub4R/GMQi2BusDgHL9enFfzYfDr4meR9n/0gjBGPn6V94/Dr4yeR5AN3jGP46/knjOP1nmP6W4UzF0eTU/p3+H/x'
    'ainSBo7oDIGV38ivqbQfHNhqcaBpkSQjrn5T9a/nU+Hfx88jyM32MY/5aV9weBv2gLWdYQ94FbA+YScV/N+b1Mdl1Z1KLenY+7zD'
    'hHK+JaXtqDUK34M/YaHUFYBlcMp5BDbhWjFfYx82OO56V8K+FfjhCyRbbxJEOOPM3ce4r3HR/irpF6qiWRUZv4lfr+FLLfFXOMom'
    'o1I4pb/82E3w7zvLpNyouUe6R/jseE9c8jyvnxjHU4r6d8JeNPI8o+bjGOpxX5/6VrnkbTv6DBGcYr0rSvGnkFf32MY/ixmv7fzP'
    'Plib+8fh2VU3Rsfqp4T+JnkeV/pGMY/ix+dfTvhL4yeR5f8ApeMYzl8ALXGcV+cZpw79ZuuW5+lZTxN7C3vH9UvhL9qzyPKzqWMY'
    '/wCW2K+l/C/7XduBGJb9G6dZMH+dfyG6V+1Z5G3/AImXTg/vf/r16VpX7Ynk7f8Aia9P+m+M1+d5l4fvENuMD9Jy3jiEYKFRpx7P'
    'X8z/2Q==')


def hash_name(name: str) -> int:
    return zlib.crc32(name.encode()) % 1000


def _jpeg_sof(w: int, h: int):
    """The good JPEG with its frame header's size replaced."""
    def make(path):
        data = bytearray(good_bytes("rgb.jpg"))
        i = 2
        while i + 4 < len(data):
            marker, length = data[i + 1], struct.unpack(">H", data[i + 2:i + 4])[0]
            if marker in (0xC0, 0xC1, 0xC2):
                data[i + 5:i + 9] = struct.pack(">HH", h, w)
                break
            i += 2 + length
        with open(path, "wb") as f:
            f.write(bytes(data))
    return make


# name -> Python expression of the array (numpy as np); ARRAYS_OK bake, the rest must raise.
ARRAYS = {
    "float64": "np.ones((32, 64, 3))",
    "int8": "np.ones((32, 64, 3), np.int8)",
    "bool": "np.ones((32, 64, 3), bool)",
    "object": "np.full((32, 64, 3), None, object)",
    "complex64": "np.ones((32, 64, 3), np.complex64)",
    "float16": "np.ones((32, 64, 3), np.float16)",
    "big_endian_float32": "np.ones((32, 64, 3), '>f4')",
    "structured": "np.zeros((32, 64, 3), [('a', 'f4')])",
    "shape_2d": "np.ones((32, 64), np.float32)",
    "shape_2_channels": "np.ones((32, 64, 2), np.float32)",
    "shape_5_channels": "np.ones((32, 64, 5), np.float32)",
    "shape_4d": "np.ones((1, 32, 64, 3), np.float32)",
    "shape_0d": "np.float32(1)",
    "empty_rows": "np.ones((0, 64, 3), np.float32)",
    "empty_cols": "np.ones((32, 0, 3), np.float32)",
    "list": "[[[1.0, 1.0, 1.0]]]",
    "none": "None",
    "string": "'world.exr'",
    "broadcast_huge": "np.broadcast_to(np.float32(1), (100000, 200000, 3))",
    "broadcast_2e31_rows": "np.broadcast_to(np.float32(1), (2**31, 1, 3))",
    "broadcast_2e31_cols": "np.broadcast_to(np.float32(1), (1, 2**31, 3))",
    "over_max_pixels": "np.broadcast_to(np.float32(1), (20000, 40000, 3))",
    "broadcast_small": "np.broadcast_to(np.float32(0.5), (32, 64, 3))",
    "fortran_order": "np.asfortranarray(np.ones((32, 64, 3), np.float32))",
    "negative_strides": "np.ones((32, 64, 3), np.float32)[::-1, ::-1]",
    "every_other_column": "np.ones((32, 128, 3), np.float32)[:, ::2]",
    "read_only": "(lambda a: (a.setflags(write=False), a)[1])(np.ones((32, 64, 3), np.float32))",
    "all_nan": "np.full((32, 64, 3), np.nan, np.float32)",
    "all_inf": "np.full((32, 64, 3), np.inf, np.float32)",
    "all_negative": "np.full((32, 64, 3), -1, np.float32)",
    "float_max": "np.full((32, 64, 3), np.finfo(np.float32).max, np.float32)",
    "subnormal": "np.full((32, 64, 3), 1e-42, np.float32)",
    "masked": "np.ma.masked_array(np.ones((32, 64, 3), np.float32), mask=False)",
    "rgba_nan_alpha": "np.dstack([np.ones((32, 64, 3), np.float32), np.full((32, 64, 1), np.nan, np.float32)])",
    "one_pixel": "np.ones((1, 1, 3), np.float32)",
    "tall": "np.ones((1000, 3, 3), np.float32)",
}
ARRAYS_OK = {"broadcast_small", "fortran_order", "negative_strides", "every_other_column", "read_only", "all_nan",
             "all_inf", "all_negative", "float_max", "subnormal", "masked", "rgba_nan_alpha", "one_pixel", "tall"}


def write_files(folder: str) -> List[str]:
    """Writes every case's input file into `folder`; returns their paths."""
    os.makedirs(folder, exist_ok=True)
    paths = []
    for c in cases():
        if c.make is None:
            continue
        p = os.path.join(folder, c.name)
        c.make(p)
        paths.append(p)
    return paths


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit("usage: corpus.py OUTDIR")
    print("%d files in %s" % (len(write_files(sys.argv[1])), sys.argv[1]))
