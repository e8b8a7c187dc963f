"""Issue 15's defects (D1..D21), each reproduced: the module, the CLI, the
output folder, the cache. The generated corpus is in tests/hostile."""
import json
import os
import signal
import stat
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import iblbake_core as ib

CLI = os.environ.get("IBLBAKE_CLI") or os.path.join(os.path.dirname(__file__), "..", "..", "build", "native", "iblbake")
SMALL = dict(face_size=16, irradiance_size=8, lut_size=16)
CLI_SMALL = ["--face-size", "16", "--irradiance-size", "8", "--lut-size", "16"]
IS_ROOT = os.geteuid() == 0


def run(*args, env=None, **kw):
    return subprocess.run([CLI, *args], capture_output=True, text=True, env=env, **kw)


def python(code, timeout=120):
    """Runs `code` in a fresh interpreter that imports the module; returns the CompletedProcess."""
    return subprocess.run([sys.executable, "-c", "import iblbake_core as ib, numpy as np\n" + textwrap.dedent(code)],
                          capture_output=True, text=True, timeout=timeout, env=dict(os.environ))


def latlong(h=32, w=64, value=1.0):
    return np.full((h, w, 3), value, dtype=np.float32)


def write_exr(path, img):
    ib.write_exr(str(path), img) if hasattr(ib, "write_exr") else None


def folder_bytes(folder):
    return {p.name: p.read_bytes() for p in sorted(Path(folder).iterdir())}


def one_line_error(r):
    lines = r.stderr.strip().splitlines()
    errors = [line for line in lines if not line.startswith("iblbake: warning:")]
    return len(errors) == 1 and errors[0].startswith("iblbake: error:")


@pytest.fixture
def src_exr(tmp_path):
    """A small lat-long EXR written by the CLI's own writer path (a baked cross read back is not needed:
    the test EXR is made from the module's bake of a gradient)."""
    path = tmp_path / "src.exr"
    img = np.linspace(0.1, 2.0, 32 * 64 * 3, dtype=np.float32).reshape(32, 64, 3)
    subprocess.run(["oiiotool", "--create", "64x32", "3", "-d", "float", "--fill:color=0.5,0.7,1.0", "0,0,64,32",
                    "-o", str(path)], check=True, capture_output=True)
    return path


# --- D1: arrays numpy cannot copy, shapes past int ----------------------------------------------

@pytest.mark.parametrize("expr", [
    "np.broadcast_to(np.float32(1), (100000, 200000, 3))",
    "np.broadcast_to(np.float32(1), (2**31, 1, 3))",
    "np.broadcast_to(np.float32(1), (1, 2**31, 3))",
])
def test_d1_huge_non_contiguous_array_raises_not_segfaults(expr):
    p = python("""
        try:
            ib.bake(%s, None, face_size=16, lut_size=16)
        except ValueError as e:
            print("ValueError:", e)
        """ % expr)
    assert p.returncode == 0, (p.returncode, p.stderr[-500:])
    assert "ValueError:" in p.stdout and "maximum" in p.stdout


# --- D4: the cache's payload is checked ---------------------------------------------------------

def test_d4_corrupt_cache_entries_are_recomputed_and_overwritten(tmp_path):
    cache = tmp_path / "cache"
    img = latlong(64, 128) + np.linspace(0, 1, 128, dtype=np.float32)[None, :, None]
    clean = ib.bake(img, lut_cache_dir=str(cache), **SMALL)
    entries = sorted(cache.glob("*.lut"))
    # (the specular normaliser is in closed form: the LUT is all the cache holds)
    assert any(e.name.startswith("brdf_lut") for e in entries)
    for e in entries:
        data = bytearray(e.read_bytes())
        k = (len(data) - 64) // 8 * 4  # the last half of the payload (the header is under 64 bytes)
        value = np.nan
        data[len(data) - k:] = np.full(k // 4, value, np.float32).tobytes()
        e.write_bytes(bytes(data))
    again = ib.bake(img, lut_cache_dir=str(cache), **SMALL)
    assert again["manifest"]["brdf_lut"]["from_cache"] is False
    np.testing.assert_array_equal(again["brdf_lut"], clean["brdf_lut"])
    for a, b in zip(again["specular"], clean["specular"]):
        np.testing.assert_array_equal(a, b)
    # ... and overwritten: a third bake reads them back.
    third = ib.bake(img, lut_cache_dir=str(cache), **SMALL)
    assert third["manifest"]["brdf_lut"]["from_cache"] is True
    np.testing.assert_array_equal(third["brdf_lut"], clean["brdf_lut"])


def test_d4_negative_control_untouched_cache_is_read(tmp_path):
    cache = tmp_path / "cache"
    ib.bake(latlong(), lut_cache_dir=str(cache), **SMALL)
    assert ib.bake(latlong(), lut_cache_dir=str(cache), **SMALL)["manifest"]["brdf_lut"]["from_cache"] is True


# --- D6: an array changed during bake() ---------------------------------------------------------

def test_d6_array_changed_during_bake_never_gives_nan(tmp_path):
    img = latlong(512, 1024) + np.linspace(0, 1, 1024, dtype=np.float32)[None, :, None]
    stop = threading.Event()

    def vandal():
        while not stop.is_set():
            img[100:400] = np.nan
            img[100:400] = 1.0

    outcomes = []
    for _ in range(6):
        t = threading.Thread(target=vandal)
        t.start()
        try:
            r = ib.bake(img, face_size=64, irradiance_size=8, lut_size=16)
            outcomes.append("ok")
            for a in [r["irradiance"], r["brdf_lut"], r["sh9"], *r["specular"]]:
                assert np.isfinite(a).all()
        except (ValueError, RuntimeError) as e:
            outcomes.append(str(e))
            assert "changed" in str(e)
        finally:
            stop.set()
            t.join()
            stop.clear()


# --- D8: a source path that is not UTF-8 --------------------------------------------------------

def test_d8_non_utf8_source_name_bakes(tmp_path, src_exr):
    weird = os.path.join(os.fsencode(tmp_path), b"w\xffrld.exr")
    os.link(os.fsencode(src_exr), weird)
    out = tmp_path / "o"
    r = subprocess.run([os.fsencode(CLI), b"bake", weird, b"-o", os.fsencode(out), *map(os.fsencode, CLI_SMALL)],
                       capture_output=True)
    assert r.returncode == 0, r.stderr
    m = json.loads((out / "manifest.json").read_text())
    assert m["source"]["path"].endswith("w\\xffrld.exr")


# --- D9: a read-only bake folder ----------------------------------------------------------------

def as_nobody():
    os.setgid(65534)
    os.setuid(65534)


def cli_nobody_can_run(folder):
    """The CLI as `nobody` reaches it: a copy in FOLDER when run as root (a
    checkout under /root, as in a fresh machine's chroot, is closed to other
    users; the CLI links only system libraries, so a copy runs as is)."""
    if not IS_ROOT:
        return CLI
    import shutil
    copy = os.path.join(str(folder), "iblbake-cli")
    shutil.copy(CLI, copy)
    os.chmod(copy, 0o755)
    return copy


def test_d9_read_only_bake_folder_is_refused_up_front(src_exr):
    import shutil
    import tempfile
    tmp_path = Path(tempfile.mkdtemp(prefix="iblbake-d9-"))  # reachable by nobody, unlike pytest's
    os.chmod(tmp_path, 0o777)
    shutil.copy(src_exr, tmp_path / "src.exr")
    src_exr = tmp_path / "src.exr"
    os.chmod(src_exr, 0o644)
    out = tmp_path / "o"
    kw = dict(preexec_fn=as_nobody) if IS_ROOT else {}
    cli = cli_nobody_can_run(tmp_path)
    r = subprocess.run([cli, "bake", str(src_exr), "-o", str(out), *CLI_SMALL, "--no-cache"], capture_output=True,
                       text=True, **kw)
    assert r.returncode == 0, r.stderr
    before = folder_bytes(out)
    os.chmod(out, 0o555)
    try:
        r = subprocess.run([cli, "bake", str(src_exr), "-o", str(out), *CLI_SMALL, "--no-cache"], capture_output=True,
                           text=True, **kw)
        assert r.returncode == 1 and one_line_error(r), r.stderr
        assert "read-only" in r.stderr
        assert folder_bytes(out) == before
        assert [p.name for p in tmp_path.iterdir() if ".iblbake-" in p.name] == []
    finally:
        os.chmod(out, 0o755)
        shutil.rmtree(tmp_path)


# --- D10: a user's own file in a bake folder ----------------------------------------------------

def test_d10_bake_folder_with_a_users_file_is_refused(tmp_path, src_exr):
    out = tmp_path / "o"
    assert run("bake", str(src_exr), "-o", str(out), *CLI_SMALL).returncode == 0
    (out / "notes.txt").write_text("mine")
    before = folder_bytes(out)
    r = run("bake", str(src_exr), "-o", str(out), *CLI_SMALL)
    assert r.returncode == 1 and one_line_error(r) and "notes.txt" in r.stderr, r.stderr
    assert folder_bytes(out) == before


def test_d10_negative_control_plain_rebake_is_allowed(tmp_path, src_exr):
    out = tmp_path / "o"
    assert run("bake", str(src_exr), "-o", str(out), *CLI_SMALL, "--format", "exr,png").returncode == 0
    r = run("bake", str(src_exr), "-o", str(out), *CLI_SMALL)
    assert r.returncode == 0, r.stderr


# --- D11: Ctrl-C during bake() ------------------------------------------------------------------

def test_d11_sigint_interrupts_python_bake_cleanly(tmp_path):
    out = tmp_path / "o"
    code = """
        import os, signal, threading, sys
        img = np.random.default_rng(1).random((2048, 4096, 3), dtype=np.float32)
        threading.Timer(0.5, lambda: os.kill(os.getpid(), signal.SIGINT)).start()
        try:
            ib.bake(img, %r, face_size=512, lut_size=512, eps=0.05, lut_cache_dir=None)
            print("FINISHED")
        except KeyboardInterrupt:
            print("INTERRUPTED")
        """ % str(out)
    p = python(code)
    assert "INTERRUPTED" in p.stdout, p.stdout + p.stderr
    assert not out.exists()
    assert [q.name for q in tmp_path.iterdir()] == []


# --- D12 / D21: CLI signals while reading and writing -------------------------------------------

def test_d21_fifo_source_is_refused_without_opening(tmp_path):
    fifo = tmp_path / "src.exr"
    os.mkfifo(fifo)
    r = run("bake", str(fifo), "-o", str(tmp_path / "o"), timeout=20)
    assert r.returncode == 1 and one_line_error(r) and "not a regular file" in r.stderr, r.stderr


@pytest.mark.parametrize("dev", ["/dev/zero", "/dev/urandom"])
def test_d21_devices_are_refused(tmp_path, dev):
    r = run("bake", dev, "-o", str(tmp_path / "o"), timeout=20)
    assert r.returncode == 1 and one_line_error(r) and "not a regular file" in r.stderr, r.stderr


def test_d21_zeros_named_exr_fail_fast(tmp_path):
    z = tmp_path / "zeros.exr"
    with open(z, "wb") as f:
        f.truncate(200 * 1024 * 1024)
    start = time.monotonic()
    r = run("bake", str(z), "-o", str(tmp_path / "o"), timeout=60)
    assert r.returncode == 1 and one_line_error(r), r.stderr
    assert time.monotonic() - start < 20


def slow_source(tmp_path):
    """A large PNG: reading it takes a while (OpenImageIO, then sRGB decode)."""
    path = tmp_path / "big.png"
    subprocess.run(["oiiotool", "--pattern", "noise", "8192x4096", "3", "-d", "uint8", "-o", str(path)],
                   check=True, capture_output=True)
    return path


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_d12_signal_while_writing_cancels_and_exits_128_plus_signal(tmp_path, src_exr, sig):
    out = tmp_path / "o"
    assert run("bake", str(src_exr), "-o", str(out), *CLI_SMALL).returncode == 0
    before = folder_bytes(out)
    # A write phase long enough to hit: a face 1024 mirror level as EXR and PNG crosses.
    p = subprocess.Popen([CLI, "bake", str(src_exr), "-o", str(out), "--face-size", "1024", "--mips", "1",
                          "--no-irradiance", "--no-lut", "--format", "exr,png"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    err = ""
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        if any(q.name.startswith(".o.iblbake-") and any(q.iterdir()) for q in tmp_path.iterdir() if q.is_dir()):
            p.send_signal(sig)
            break
        time.sleep(0.005)
    _, err = p.communicate(timeout=120)
    assert p.returncode == 128 + sig, (p.returncode, err)
    assert folder_bytes(out) == before
    assert [q.name for q in tmp_path.iterdir() if ".iblbake-" in q.name] == []


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_d21_signal_while_reading_stops_at_once(tmp_path, sig):
    src = slow_source(tmp_path)
    out = tmp_path / "o"
    p = subprocess.Popen([CLI, "bake", str(src), "-o", str(out), *CLI_SMALL], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True)
    time.sleep(0.3)
    p.send_signal(sig)
    start = time.monotonic()
    _, err = p.communicate(timeout=60)
    assert time.monotonic() - start < 5
    assert p.returncode == 128 + sig, (p.returncode, err)
    assert not out.exists()


# --- D14: non-finite numbers --------------------------------------------------------------------

def test_d14_nan_in_manifest_extra_says_finite(tmp_path):
    with pytest.raises(ValueError, match="finite"):
        ib.bake(latlong(), str(tmp_path / "o"), manifest_extra={"x": float("nan")}, **SMALL)
    assert not (tmp_path / "o").exists()


# --- D15: out_dir types -------------------------------------------------------------------------

def test_d15_out_dir_accepts_paths_and_bytes(tmp_path):
    ib.bake(latlong(), tmp_path / "a", **SMALL)
    ib.bake(latlong(), os.fsencode(tmp_path / "b"), **SMALL)
    assert (tmp_path / "a" / "manifest.json").is_file() and (tmp_path / "b" / "manifest.json").is_file()


@pytest.mark.parametrize("bad", [123, 1.5, ["x"], object()])
def test_d15_out_dir_rejects_other_objects(tmp_path, bad, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(TypeError):
        ib.bake(latlong(), bad, **SMALL)
    assert list(tmp_path.iterdir()) == []


# --- D16: long output names ---------------------------------------------------------------------

def test_d16_a_250_character_output_name_bakes(tmp_path):
    out = tmp_path / ("n" * 250)
    ib.bake(latlong(), str(out), **SMALL)
    assert (out / "manifest.json").is_file()
    ib.bake(latlong(), str(out), **SMALL)  # and a rebake over it


# --- D17: warnings ------------------------------------------------------------------------------

def test_d17_non_2_to_1_source_warns():
    r = ib.bake(latlong(32, 32), **SMALL)
    assert any("2:1" in w for w in r["manifest"]["warnings"])
    assert ib.bake(latlong(32, 64), **SMALL)["manifest"]["warnings"] == []  # negative control


def test_d17_cli_warnings_on_stderr_and_in_manifest(tmp_path):
    src = tmp_path / "two.exr"
    subprocess.run(["oiiotool", "--create", "64x32", "2", "-d", "half", "--chnames", "R,G", "-o", str(src)],
                   check=True, capture_output=True)
    out = tmp_path / "o"
    r = run("bake", str(src), "-o", str(out), *CLI_SMALL)
    assert r.returncode == 0, r.stderr
    warns = [line for line in r.stderr.splitlines() if line.startswith("iblbake: warning:")]
    assert warns and any("channel" in w for w in warns), r.stderr
    m = json.loads((out / "manifest.json").read_text())
    assert any("channel" in w for w in m["warnings"])


def test_d17_all_outputs_disabled_warns(tmp_path, src_exr):
    r = run("bake", str(src_exr), "-o", str(tmp_path / "o"), "--no-irradiance", "--no-specular", "--no-lut")
    assert r.returncode == 0 and "iblbake: warning:" in r.stderr and "manifest.json alone" in r.stderr, r.stderr


def test_d17_data_window_outside_display_window_warns(tmp_path):
    src = tmp_path / "shifted.exr"
    subprocess.run(["oiiotool", "--create", "64x32", "3", "-d", "half", "--origin", "+40+0", "--fullsize", "64x32",
                    "-o", str(src)], check=True, capture_output=True)
    r = run("bake", str(src), "-o", str(tmp_path / "o"), *CLI_SMALL)
    assert r.returncode == 0 and "data window" in r.stderr, r.stderr


# --- D18: a progress callback returning something else ------------------------------------------

def test_d18_progress_returning_non_bool_is_a_clear_type_error():
    with pytest.raises(TypeError, match="progress"):
        ib.bake(latlong(), progress=lambda s, f: "yes", **SMALL)
    ib.bake(latlong(), progress=lambda s, f: None, **SMALL)  # None: go on
    ib.bake(latlong(), progress=lambda s, f: np.bool_(True), **SMALL)


# --- D19: messages ------------------------------------------------------------------------------

def test_d19_raw_bytes_are_not_echoed(tmp_path):
    import struct
    # A channel named 0xFF 0xFE with an invalid pixel type: OpenEXR's message quotes the name.
    h = corpus.exr_bytes()
    v = h.replace(b"B\0\x02\0\0\0", b"\xff\xfe\0\x07\0\0\0", 1)
    i = v.index(b"chlist\0") + 7
    v = v[:i] + struct.pack("<i", struct.unpack("<i", v[i:i + 4])[0] + 1) + v[i + 4:]
    bad = tmp_path / "bad.exr"
    bad.write_bytes(v)
    r = subprocess.run([CLI, "bake", str(bad), "-o", str(tmp_path / "o")], capture_output=True)
    assert r.returncode == 1
    err = r.stderr.decode("utf-8")  # valid UTF-8 ...
    assert all(c.isprintable() for c in err.strip()), err  # ... and printable
    assert err.count("\n") == 1


def test_d19_dangling_symlink_output_is_explained(tmp_path, src_exr):
    link = tmp_path / "o"
    link.symlink_to(tmp_path / "nowhere")
    r = run("bake", str(src_exr), "-o", str(link), *CLI_SMALL)
    assert r.returncode == 1 and one_line_error(r), r.stderr
    assert "filesystem error" not in r.stderr and "symbolic link" in r.stderr


def test_d19_fis_only_options_warn_with_the_default_method(tmp_path, src_exr):
    r = run("bake", str(src_exr), "-o", str(tmp_path / "o"), *CLI_SMALL, "--samples", "64")
    assert r.returncode == 0 and "iblbake: warning:" in r.stderr and "--samples" in r.stderr, r.stderr


def test_d19_reported_time_includes_reading(tmp_path, src_exr):
    out = tmp_path / "o"
    r = run("bake", str(src_exr), "-o", str(out), *CLI_SMALL)
    m = json.loads((out / "manifest.json").read_text())
    assert "read" in m["timings"], m["timings"]


# --- D20: staging litter of killed bakes --------------------------------------------------------

def test_d20_stale_staging_of_dead_pids_is_cleaned_in_the_parent(tmp_path, src_exr):
    dead = subprocess.Popen(["true"])
    dead.wait()
    litter = [tmp_path / (".other.iblbake-%d-0123abcd" % dead.pid)]
    litter[0].mkdir()
    (litter[0] / "irradiance.exr").write_bytes(b"half")
    alive = tmp_path / (".busy.iblbake-%d-0123abcd" % os.getpid())
    alive.mkdir()
    r = run("bake", str(src_exr), "-o", str(tmp_path / "o"), *CLI_SMALL)
    assert r.returncode == 0, r.stderr
    assert not litter[0].exists()
    assert alive.exists()  # a live process's staging is left alone


# --- D3 (and D17's Blender-side warnings): the add-on core's skip check -------------------------

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "addon"))
from iblbake.core import pipeline  # noqa: E402
from iblbake.core.settings import BakeSettings  # noqa: E402
from iblbake.core.world import IMAGE, RENDER, WorldSource  # noqa: E402


def settings(tmp_path, **kw):
    return BakeSettings(out_dir=str(tmp_path / "out"), face_size=16, irradiance_size=8, lut_size=16,
                        lut_cache_dir=str(tmp_path / "cache"), **kw)


def test_d3_a_damaged_file_is_baked_again_not_unchanged(tmp_path):
    src, px = WorldSource(IMAGE, world="w"), latlong(32, 64, 0.5)
    assert pipeline.bake(src, px, settings(tmp_path)).status == "baked"
    m = json.loads((tmp_path / "out" / "manifest.json").read_text())
    assert set(m["files"]) >= {"irradiance.exr", "specular_0.exr", "brdf_lut.exr"}
    for name, f in m["files"].items():
        data = (tmp_path / "out" / name).read_bytes()
        assert f["bytes"] == len(data)
    assert pipeline.bake(src, px, settings(tmp_path)).status == "unchanged"  # negative control
    spec0 = tmp_path / "out" / "specular_0.exr"
    spec0.write_bytes(spec0.read_bytes()[:300])  # truncated
    assert pipeline.bake(src, px, settings(tmp_path)).status == "baked"
    assert len(spec0.read_bytes()) == m["files"]["specular_0.exr"]["bytes"]
    data = bytearray(spec0.read_bytes())
    data[-5] ^= 0xFF  # same size, other bytes
    spec0.write_bytes(bytes(data))
    assert pipeline.bake(src, px, settings(tmp_path)).status == "baked"


def test_d17_negative_strength_and_no_world_warn(tmp_path, capfd):
    src = WorldSource(IMAGE, world="w", strength=-1.0)
    rep = pipeline.bake(src, -latlong(), settings(tmp_path))
    assert any("Strength" in w for w in rep.manifest["warnings"])
    assert "iblbake: warning:" in capfd.readouterr().err
    rep = pipeline.bake(WorldSource(RENDER, "the scene has no world", world=None), latlong(),
                        settings(tmp_path, force=True))
    assert any("no world" in w for w in rep.manifest["warnings"])


# --- D5: declared-size bombs; D7: truncated JPEG ------------------------------------------------

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "hostile"))
import corpus  # noqa: E402


def peak_run(argv):
    """(returncode, stderr, peak RSS in MB) of one CLI run. Run under GNU
    time, a small process: a child forked straight from pytest reports at
    least pytest's own size as its peak (Linux keeps the high-water mark of
    the memory a process had before exec), 306 MB once numpy, matplotlib and
    earlier bakes have grown it."""
    import tempfile
    with tempfile.NamedTemporaryFile("r") as report:
        p = subprocess.run(["/usr/bin/time", "-f", "%M", "-o", report.name, *argv], capture_output=True)
        lines = [line for line in report.read().splitlines() if line.strip()]
    return p.returncode, p.stderr.decode(), int(lines[-1]) / 1024


@pytest.mark.parametrize("name, data", [
    ("display.exr", corpus.exr_bytes(display_window=(0, 0, 24575, 12287))),
    ("header_only.exr", corpus.exr_bytes(data_window=(0, 0, 29999, 15999), chunks=False)),
    ("over_max.exr", corpus.exr_bytes(data_window=(0, 0, 39999, 19999), chunks=False)),
    ("over_max.png", corpus.png_bytes(40000, 20000)),
    ("under_max.png", corpus.png_bytes(30000, 16000)),
    ("under_max.hdr", corpus.hdr_bytes(30000, 16000, rows=0)),
    # Found by the fuzzer: an attribute declaring 1.9 GB in an 819-byte file (OpenEXR 3.1 allocated it).
    ("attribute.exr", corpus.exr_bytes()[:8] + b"capDate\0string\0" + (1936286739).to_bytes(4, "little") + b"x" * 700),
])
def test_d5_declared_size_bombs_stay_small(tmp_path, name, data):
    src = tmp_path / name
    src.write_bytes(data)
    rc, err, mb = peak_run([CLI, "bake", str(src), "-o", str(tmp_path / "o"), *CLI_SMALL])
    assert mb < 300, "peak %.0f MB (%s)" % (mb, err)
    if name == "display.exr":  # the data window alone is baked, with a warning
        assert rc == 0 and "data window" in err, err
    else:
        assert rc == 1 and one_line_error(err_proc(err)), err


def err_proc(err):
    return subprocess.CompletedProcess([], 1, "", err)


def test_d7_truncated_jpeg_is_an_error(tmp_path):
    good = tmp_path / "good.jpg"
    subprocess.run(["oiiotool", "--pattern", "noise", "256x128", "3", "-d", "uint8", "-o", str(good)], check=True,
                   capture_output=True)
    data = good.read_bytes()
    assert run("bake", str(good), "-o", str(tmp_path / "ok"), *CLI_SMALL).returncode == 0  # negative control
    for keep in (0.01, 0.5, 0.95):
        cut = tmp_path / ("cut%d.jpg" % int(keep * 100))
        cut.write_bytes(data[:max(4, int(len(data) * keep))])
        r = run("bake", str(cut), "-o", str(tmp_path / "o"), *CLI_SMALL)
        assert r.returncode == 1 and one_line_error(r) and "truncated" in r.stderr, r.stderr
