"""Runs the hostile-input corpus (corpus.py) through the CLI and the Python
module. Every case asserts (issue 15):
  - a clear one-line error (exit 1), or a bake (exit 0) whose repairs are
    counted (bad_input) or warned about; a cut file that bakes must bake what
    the whole file does;
  - an exit code of 0 or 1, never a signal;
  - no NaN or Inf in any output file or in the manifest's numbers;
  - the earlier bake in the output folder byte-identical after any failure,
    and no staging folder left behind;
  - peak memory (the child's maxrss) within PEAK_MB.
The summary at the end gives the counts."""
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import corpus  # noqa: E402

ROOT = os.path.abspath(os.path.join(HERE, "..", ".."))
CLI = os.environ.get("IBLBAKE_CLI") or os.path.join(ROOT, "build", "native", "iblbake")
PEAK_MB = 400  # the bound every case must stay within (a small bake uses about 40 MB)
SMALL = ["--face-size", "16", "--irradiance-size", "8", "--lut-size", "16", "--mips", "3"]
IS_ROOT = os.geteuid() == 0

CASES = corpus.cases()
STATS = {"cases": 0, "errors": 0, "baked": 0, "repairs_counted": 0, "warned": 0, "crashes": 0, "nan": 0,
         "lost_bakes": 0, "hangs": 0, "wrong": 0, "peak_kb": 0, "peak_case": "", "skipped": 0}


@pytest.fixture(scope="session")
def work():
    d = tempfile.mkdtemp(prefix="iblbake-corpus-")
    os.chmod(d, 0o755)
    good = os.path.join(d, "source.exr")
    corpus.make_good(good, "half_zip.exr")
    cache = os.path.join(d, "cache")
    earlier = os.path.join(d, "earlier")
    r = subprocess.run([CLI, "bake", good, "-o", earlier, *SMALL, "--cache-dir", cache, "-q"], capture_output=True,
                       text=True)
    assert r.returncode == 0, r.stderr
    yield {"dir": d, "good": good, "cache": cache, "earlier": earlier, "refs": {}}
    shutil.rmtree(d, ignore_errors=True)


def snapshot(folder):
    out = {}
    for base, _, files in os.walk(folder):
        for f in files:
            p = os.path.join(base, f)
            with open(p, "rb") as fh:
                out[os.path.relpath(p, folder)] = fh.read()
    return out


def run_measured(argv, timeout=120, env=None, preexec_fn=None, cwd=None):
    """(returncode, stdout, stderr, peak RSS in kB) of one child."""
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        p = subprocess.Popen(argv, stdout=out, stderr=err, env=env, preexec_fn=preexec_fn, cwd=cwd)
        start = time.monotonic()
        while True:
            pid, status, usage = os.wait4(p.pid, os.WNOHANG)
            if pid:
                break
            if time.monotonic() - start > timeout:
                STATS["hangs"] += 1
                p.kill()
                pid, status, usage = os.wait4(p.pid, 0)
                raise AssertionError("timed out after %d s: %s" % (timeout, argv))
            time.sleep(0.01)
        p.returncode = os.waitstatus_to_exitcode(status)
        out.seek(0)
        err.seek(0)
        return p.returncode, out.read().decode("utf-8", "replace"), err.read().decode("utf-8", "strict"), usage.ru_maxrss


def record_peak(name, kb):
    if kb > STATS["peak_kb"]:
        STATS["peak_kb"], STATS["peak_case"] = kb, name


BARE = ("std::bad_alloc", "Invalid argument.", "filesystem error", "json.exception", "basic_string", "pybind11")


def check_error_text(stderr):
    lines = [line for line in stderr.strip().splitlines() if line]
    errors = [line for line in lines if not line.startswith("iblbake: warning:")]
    assert len(errors) == 1 and errors[0].startswith("iblbake: error:"), stderr
    text = errors[0]
    assert text.isprintable() and len(text) < 500, text
    assert not any(b in text for b in BARE), text
    assert len(text) > len("iblbake: error: ") + 10, text


def check_outputs(folder):
    """No NaN or Inf in any output file or manifest number."""
    import iblbake_core as ib
    import numpy as np
    with open(os.path.join(folder, "manifest.json")) as f:
        m = json.load(f)

    def numbers(x):
        if isinstance(x, dict):
            for v in x.values():
                yield from numbers(v)
        elif isinstance(x, list):
            for v in x:
                yield from numbers(v)
        elif isinstance(x, float):
            yield x
    bad = [v for v in numbers(m) if not math.isfinite(v)]
    for name in os.listdir(folder):
        if name.endswith(".exr"):
            a = ib.read_image(os.path.join(folder, name))
            if not np.isfinite(a).all():
                bad.append(name)
    if bad:
        STATS["nan"] += 1
    assert not bad, bad
    return m


def outcome(case, rc, stderr, out, earlier_bytes, parent):
    """The checks every case shares; returns the manifest of a bake, or None."""
    STATS["cases"] += 1
    if rc < 0 or rc > 1:
        STATS["crashes"] += 1
    assert rc in (0, 1), (rc, stderr)
    if case.expect == "error":
        assert rc == 1, "expected a refusal: " + stderr
    if case.expect == "ok":
        assert rc == 0, stderr
    if rc == 1:
        STATS["errors"] += 1
        check_error_text(stderr)
        if earlier_bytes is not None:
            if snapshot(out) != earlier_bytes:
                STATS["lost_bakes"] += 1
            assert snapshot(out) == earlier_bytes, "the earlier bake changed"
        if parent is not None:
            litter = [n for n in os.listdir(parent) if ".iblbake-" in n]
            assert not litter, litter
        return None
    STATS["baked"] += 1
    m = check_outputs(out)
    if m["bad_input"]["pixels"]:
        STATS["repairs_counted"] += 1
    if m.get("warnings"):
        STATS["warned"] += 1
    return m


def cli_case(case, work, source, extra=(), out=None, preexec_fn=None, cwd=None, prefill=True, cli=None):
    parent = tempfile.mkdtemp(prefix="case-", dir=work["dir"])
    out = out or os.path.join(parent, "out")
    if prefill:
        shutil.copytree(work["earlier"], out)
    before = snapshot(out) if os.path.isdir(out) else None
    rc, _, err, kb = run_measured([cli or CLI, "bake", source, "-o", out, *SMALL, "--cache-dir", work["cache"],
                                   *extra], preexec_fn=preexec_fn, cwd=cwd)
    record_peak(case.name, kb)
    m = outcome(case, rc, err, out, before, parent)
    assert kb < PEAK_MB * 1024, "peak memory %d MB" % (kb // 1024)
    return rc, m, err, parent


def reference_sh9(work, good_name):
    if good_name not in work["refs"]:
        src = os.path.join(work["dir"], good_name.replace("good_", "ref_"))
        corpus.make_good(src, good_name[len("good_"):])
        out = os.path.join(work["dir"], good_name + ".out")
        r = subprocess.run([CLI, "bake", src, "-o", out, *SMALL, "--cache-dir", work["cache"], "-q"],
                           capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
        with open(os.path.join(out, "manifest.json")) as f:
            work["refs"][good_name] = json.load(f)["sh9"]
    return work["refs"][good_name]


FILE_KINDS = ("good", "truncation", "fuzz", "bomb", "odd", "looks_right")


def wrong_result(case, ok):
    """A bake that exited 0 with what it should not have baked (issue 24) is counted and fails."""
    if not ok:
        STATS["wrong"] += 1
    return ok


@pytest.mark.parametrize("case", [c for c in CASES if c.kind in FILE_KINDS], ids=lambda c: c.name)
def test_file(case, work):
    src = os.path.join(work["dir"], case.name)
    case.make(src)
    rc, m, err, parent = cli_case(case, work, src, case.args)
    if rc == 0 and case.mean is not None:
        import numpy as np
        assert wrong_result(case, np.allclose(m["mean_radiance"], case.mean, rtol=0.02, atol=1e-6)), \
            (m["mean_radiance"], case.mean, m["warnings"])
    if rc == 0 and case.same_as is not None:
        import numpy as np
        ref = src + ".reference" + os.path.splitext(src)[1].replace(".tif", ".exr")
        case.same_as(ref)
        ref_out = src + ".reference.out"
        r = subprocess.run([CLI, "bake", ref, "-o", ref_out, *SMALL, "--cache-dir", work["cache"], "-q"],
                           capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
        with open(os.path.join(ref_out, "manifest.json")) as f:
            want = json.load(f)["sh9"]
        assert wrong_result(case, np.allclose(m["sh9"], want, rtol=1e-4, atol=1e-6)), "baked turned or mirrored"
    if rc == 0 and "source" in case.args:  # RGBE's range: the brightest texels clamped, not written black
        import iblbake_core as ib
        hdr = ib.read_image(os.path.join(parent, "out", "source", "source.hdr"))
        assert wrong_result(case, float(hdr.min()) > 1e38), "source.hdr holds black texels"
    if rc == 0 and case.reference:  # a cut file that bakes lost nothing
        import numpy as np
        np.testing.assert_allclose(m["sh9"], reference_sh9(work, case.reference), rtol=1e-5, atol=1e-7,
                                   err_msg="a truncated file baked something else")
    if rc == 0 and case.name.startswith(("odd_nan", "odd_inf", "odd_negative.", "odd_mixed")):
        assert m["bad_input"]["pixels"] > 0  # the repair is counted


@pytest.mark.parametrize("case", [c for c in CASES if c.kind == "notafile"], ids=lambda c: c.name)
def test_not_a_file(case, work):
    d = tempfile.mkdtemp(prefix="src-", dir=work["dir"])
    src = os.path.join(d, case.name)
    if case.make:
        case.make(src)
    elif case.name == "special_fifo.exr":
        os.mkfifo(src)
    elif case.name.startswith("special_dev_"):
        src = "/dev/" + case.name[len("special_dev_"):]
    elif case.name == "special_directory.exr":
        os.mkdir(src)
    elif case.name == "special_dangling_link.exr":
        os.symlink(os.path.join(d, "nowhere.exr"), src)
    elif case.name == "special_link_to_good.exr":
        os.symlink(work["good"], src)
    cli_case(case, work, src)


def as_nobody():
    os.setgid(65534)
    os.setuid(65534)


def mount_tmpfs(path, size):
    os.makedirs(path, exist_ok=True)
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=%s" % size, "tmpfs", path], capture_output=True)
    return r.returncode == 0


@pytest.mark.parametrize("case", [c for c in CASES if c.kind == "output"], ids=lambda c: c.name)
def test_output_folder(case, work):
    good = work["good"]
    name = case.name
    if name == "out_read_only" or name == "out_parent_read_only":
        parent = tempfile.mkdtemp(prefix="ro-", dir="/tmp")
        os.chmod(parent, 0o777)
        src = os.path.join(parent, "src.exr")
        shutil.copy(good, src)
        os.chmod(src, 0o644)
        out = os.path.join(parent, "sub", "out")
        os.makedirs(os.path.dirname(out))
        os.chmod(os.path.dirname(out), 0o777)
        shutil.copytree(work["earlier"], out)
        for base, dirs, files in os.walk(parent):
            for x in dirs + files:
                os.chown(os.path.join(base, x), 65534, 65534) if IS_ROOT else None
        # nobody runs a copy of the CLI: a checkout under /root (a fresh
        # machine's chroot) is closed to other users; the CLI links only
        # system libraries.
        cli = os.path.join(parent, "iblbake-cli")
        shutil.copy(CLI, cli)
        os.chmod(cli, 0o755)
        locked = out if name == "out_read_only" else os.path.dirname(out)
        os.chmod(locked, 0o555)
        try:
            cli_case(case, work, src, out=out, prefill=False, preexec_fn=as_nobody if IS_ROOT else None, cli=cli)
        finally:
            os.chmod(locked, 0o755)
            shutil.rmtree(parent, ignore_errors=True)
        return
    if name in ("out_full_disk", "out_read_only_file_system"):
        if not IS_ROOT:
            STATS["skipped"] += 1
            pytest.skip("a small tmpfs needs root to mount")
        mnt = tempfile.mkdtemp(prefix="tmpfs-", dir=work["dir"])
        if not mount_tmpfs(mnt, "320k"):
            STATS["skipped"] += 1
            pytest.skip("mount -t tmpfs is not permitted here")
        try:
            out = os.path.join(mnt, "out")
            shutil.copytree(work["earlier"], out)
            if name == "out_full_disk":
                free = shutil.disk_usage(mnt).free
                with open(os.path.join(mnt, "filler"), "wb") as f:
                    f.write(b"\0" * max(0, free - 8192))
            else:
                subprocess.run(["mount", "-o", "remount,ro", mnt], check=True)
            before = snapshot(out)
            rc, _, err, kb = run_measured([CLI, "bake", good, "-o", out, *SMALL, "--cache-dir", work["cache"],
                                           "--format", "exr,png"])
            record_peak(name, kb)
            outcome(case, rc, err, out, before, mnt)
        finally:
            subprocess.run(["umount", mnt], capture_output=True)
        return
    parent = tempfile.mkdtemp(prefix="case-", dir=work["dir"])
    out = os.path.join(parent, "out")
    extra, cwd, prefill = [], None, True
    if name == "out_is_a_file":
        prefill = False
        with open(out, "w") as f:
            f.write("x")
    elif name == "out_dangling_link":
        prefill = False
        os.symlink(os.path.join(parent, "nowhere"), out)
    elif name == "out_link_to_bake":
        prefill = False
        shutil.copytree(work["earlier"], os.path.join(parent, "real"))
        os.symlink(os.path.join(parent, "real"), out)
    elif name == "out_not_a_bake":
        prefill = False
        os.mkdir(out)
        with open(os.path.join(out, "thesis.tex"), "w") as f:
            f.write("mine")
    elif name == "out_bake_with_users_file":
        shutil.copytree(work["earlier"], out)
        prefill = False
        with open(os.path.join(out, "notes.txt"), "w") as f:
            f.write("mine")
    elif name == "out_damaged_manifest":
        shutil.copytree(work["earlier"], out)
        prefill = False
        with open(os.path.join(out, "manifest.json"), "w") as f:
            f.write('{"generator": "iblbake", "specular": [')
        with open(os.path.join(out, "notes.txt"), "w") as f:
            f.write("mine")
    elif name == "out_name_250":
        out = os.path.join(parent, "n" * 250)
    elif name == "out_name_256":
        out = os.path.join(parent, "n" * 256)
        prefill = False
    elif name == "out_deep_new_parent":
        out = os.path.join(parent, "a", "b", "c", "out")
        prefill = False
    elif name == "out_holds_source":
        shutil.copytree(work["earlier"], out)
        prefill = False
        shutil.copy(good, os.path.join(out, "src.exr"))
        good = os.path.join(out, "src.exr")
    elif name == "out_current_folder":
        shutil.copytree(work["earlier"], out)
        prefill = False
        cwd = out
        out = "."
    elif name == "out_root":
        prefill = False
        out = "/"
    if out in (".", "/"):
        rc, _, err, kb = run_measured([CLI, "bake", good, "-o", out, *SMALL, "--cache-dir", work["cache"]], cwd=cwd)
        record_peak(name, kb)
        outcome(case, rc, err, cwd or parent, snapshot(cwd) if cwd else None, None)
        return
    cli_case(case, work, good, extra, out=out, prefill=prefill)


@pytest.mark.parametrize("case", [c for c in CASES if c.kind == "option"], ids=lambda c: c.name)
def test_option(case, work):
    cli_case(case, work, work["good"], case.args)


ARRAY_SCRIPT = r"""
import sys, numpy as np, iblbake_core as ib
image = %s
try:
    r = ib.bake(image, sys.argv[1], face_size=16, irradiance_size=8, lut_size=16, mip_count=3,
                lut_cache_dir=sys.argv[2])
except (ValueError, TypeError, MemoryError) as e:
    print("iblbake: error: %%s: %%s" %% (type(e).__name__, e), file=sys.stderr)
    sys.exit(1)
"""


@pytest.mark.parametrize("case", [c for c in CASES if c.kind == "array"], ids=lambda c: c.name)
def test_array(case, work):
    parent = tempfile.mkdtemp(prefix="case-", dir=work["dir"])
    out = os.path.join(parent, "out")
    shutil.copytree(work["earlier"], out)
    before = snapshot(out)
    rc, _, err, kb = run_measured([sys.executable, "-c", ARRAY_SCRIPT % corpus.ARRAYS[case.name[len("array_"):]],
                                   out, work["cache"]], env=dict(os.environ))
    record_peak(case.name, kb)
    m = outcome(case, rc, err, out, before, parent)
    assert kb < PEAK_MB * 1024, "peak memory %d MB" % (kb // 1024)
    if m is not None and case.name in ("array_all_nan", "array_all_inf", "array_all_negative", "array_rgba_nan_alpha"):
        assert m["bad_input"]["pixels"] > 0 or case.name == "array_rgba_nan_alpha"


# --- issue 24: the LUT cache, the output folder during a bake, Blender worlds --------------------------

FORMATS = ["--format", "exr,png"]


def cli(*args, timeout=120):
    rc, out, err, kb = run_measured([CLI, "bake", *args], timeout=timeout)
    return rc, err


def damage_cache(name, cache, work, d):
    """Damages the cache entries a bake of the good source with both LUT models left."""
    entries = sorted(os.listdir(cache))
    luts = [os.path.join(cache, n) for n in entries if n.endswith(".lut")]
    encs = [os.path.join(cache, n) for n in entries if n.endswith(".enc")]
    karis = [p for p in luts if "-karis-" in p]

    def swap(a, b):
        os.rename(a, a + ".x")
        os.rename(b, a)
        os.rename(a + ".x", b)
    if name == "lut_models_swapped":
        swap(*luts)
    elif name == "enc_exr_png_swapped":
        by_table = {}
        for p in encs:
            by_table.setdefault(p.split("-exr-")[0].split("-png-")[0], []).append(p)
        for pair in by_table.values():
            if len(pair) == 2:
                swap(*pair)
    elif name in ("lut_truncated", "enc_truncated"):
        for p in luts if name.startswith("lut") else encs:
            os.truncate(p, os.path.getsize(p) // 2)
    elif name in ("lut_fifo", "enc_fifo"):
        for p in luts if name.startswith("lut") else encs:
            os.remove(p)
            os.mkfifo(p)
    elif name == "lut_symlink":
        os.remove(karis[0])
        os.symlink([p for p in luts if p != karis[0]][0], karis[0])
    elif name == "lut_directory":
        os.remove(karis[0])
        os.mkdir(karis[0])
    elif name == "lut_renamed_from_other_size":
        other = os.path.join(d, "other-cache")
        small = SMALL[:SMALL.index("--lut-size")] + SMALL[SMALL.index("--lut-size") + 2:]
        rc, err = cli(work["good"], "-o", os.path.join(d, "o32"), *small, "--lut-size", "32", "--cache-dir", other)
        assert rc == 0, err
        big = [n for n in os.listdir(other) if n.endswith(".lut") and "-karis-" in n][0]
        os.remove(karis[0])
        shutil.copy(os.path.join(other, big), karis[0])


@pytest.mark.parametrize("case", [c for c in CASES if c.kind == "cache"], ids=lambda c: c.name)
def test_cache(case, work):
    d = tempfile.mkdtemp(prefix="cache-", dir=work["dir"])
    cache, ref, out = os.path.join(d, "cache"), os.path.join(d, "ref"), os.path.join(d, "out")
    rc, err = cli(work["good"], "-o", ref, *SMALL, *FORMATS, "--no-cache")
    assert rc == 0, err
    for model in ("karis", "height-correlated"):
        rc, err = cli(work["good"], "-o", os.path.join(d, model), *SMALL, *FORMATS, "--lut-model", model,
                      "--cache-dir", cache)
        assert rc == 0, err
    damage_cache(case.name[len("cache_"):], cache, work, d)
    rc, _, err, kb = run_measured([CLI, "bake", work["good"], "-o", out, *SMALL, *FORMATS, "--cache-dir", cache],
                                  timeout=60)
    record_peak(case.name, kb)
    outcome(case, rc, err, out, None, d)
    for name in ("brdf_lut.exr", "brdf_lut.png"):
        with open(os.path.join(out, name), "rb") as a, open(os.path.join(ref, name), "rb") as b:
            assert wrong_result(case, a.read() == b.read()), name + " differs from a bake without the cache"


def slow_bake(work):
    src = os.path.join(work["dir"], "slow.exr")
    if not os.path.exists(src):
        corpus.make_gradient_exr(src, 1024, 512)
    return [src, "--face-size", "512", "--mips", "2", "--irradiance-size", "32", "--lut-size", "64", *FORMATS,
            "--no-cache"]


@pytest.mark.parametrize("case", [c for c in CASES if c.kind == "during"], ids=lambda c: c.name)
def test_output_changed_during_a_bake(case, work):
    import fcntl
    name = case.name[len("during_"):]
    parent = tempfile.mkdtemp(prefix="during-", dir=work["dir"])
    out = os.path.join(parent, "out")
    if name in ("file_added_to_earlier_bake", "earlier_bake_removed"):
        shutil.copytree(work["earlier"], out)
    before = snapshot(out) if os.path.isdir(out) else None
    mine = {}  # the user's files: path -> bytes, all kept
    lock = None

    def act():
        if name == "file_added_to_earlier_bake":
            mine[os.path.join(out, "notes.txt")] = b"notes"
        elif name == "folder_made_at_path":
            os.mkdir(out)
            mine[os.path.join(out, "thesis.tex")] = b"mine"
        elif name == "empty_folder_made_at_path":
            os.mkdir(out)
        elif name == "earlier_bake_removed":
            shutil.rmtree(out)
        for p, data in mine.items():
            with open(p, "wb") as f:
                f.write(data)
    if name == "locked_staging_of_other_namespace":
        dead = subprocess.Popen(["true"])
        dead.wait()
        staging = os.path.join(parent, ".other.iblbake-%d-0123abcd" % dead.pid)
        os.mkdir(staging)
        mine[os.path.join(staging, "specular_0.exr")] = b"half written"
        act()
        lock = os.open(staging, os.O_RDONLY | os.O_DIRECTORY)
        fcntl.flock(lock, fcntl.LOCK_EX)
        argv = [CLI, "bake", work["good"], "-o", out, *SMALL, "--cache-dir", work["cache"]]
    else:
        argv = [CLI, "bake", *slow_bake(work)[:1], "-o", out, *slow_bake(work)[1:]]
    try:
        with tempfile.TemporaryFile() as errf:
            p = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=errf)
            if lock is None:
                deadline = time.monotonic() + 60
                while p.poll() is None and not any(".out.iblbake-" in n for n in os.listdir(parent)):
                    assert time.monotonic() < deadline
                    time.sleep(0.002)
                acted_while_running = p.poll() is None
                act()
                assert acted_while_running, "the bake ended before the folder was changed"
            try:
                p.wait(timeout=300)
            except subprocess.TimeoutExpired:
                STATS["hangs"] += 1
                p.kill()
                raise
            errf.seek(0)
            err = errf.read().decode()
    finally:
        if lock is not None:
            os.close(lock)
    outcome(case, p.returncode, err, out, None, None)
    lost = [q for q, data in mine.items() if not os.path.isfile(q) or open(q, "rb").read() != data]
    if before is not None and p.returncode == 1:
        now = snapshot(out)
        lost += [k for k, v in before.items() if now.get(k) != v]
    if lost:
        STATS["lost_bakes"] += 1
    assert not lost, lost
    if p.returncode == 1:
        assert not [n for n in os.listdir(parent) if ".out.iblbake-" in n]


BLENDER_EXE = shutil.which("blender")


@pytest.mark.parametrize("case", [c for c in CASES if c.kind == "blender"], ids=lambda c: c.name)
def test_blender_world(case, work):
    if BLENDER_EXE is None:
        STATS["skipped"] += 1
        pytest.skip("no Blender")
    kind = case.name[len("blender_"):]
    d = tempfile.mkdtemp(prefix="blender-", dir=work["dir"])
    env = dict(os.environ, IBLBAKE_CORE_DIR=os.path.dirname(__import__("iblbake_core").__file__),
               IBLBAKE_CACHE_DIR=work["cache"])
    cases_py = os.path.join(ROOT, "tests", "blender", "cases.py")
    r = subprocess.run([BLENDER_EXE, "-b", "--factory-startup", "--python-exit-code", "1", "--python", cases_py, "--",
                        "save_hostile_world", d, "kind=" + kind, "value=1000"], capture_output=True, text=True,
                       env=env, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    out = os.path.join(d, "out")
    rc, _, err, kb = run_measured([BLENDER_EXE, "-b", "--factory-startup", os.path.join(d, "scene.blend"), "--python",
                                   os.path.join(ROOT, "blender_scripts", "bake_world.py"), "--", "--out", out,
                                   *SMALL[:6]], timeout=600, env=env)
    err = "\n".join(line for line in err.splitlines() if line.startswith("iblbake:"))
    m = outcome(case, rc, err, out, None, None)
    if m is not None and kind == "srgb_float":
        # Cycles shows 1000 in sRGB as 1.39e7 (Blender's buffer of it held 40.5).
        assert wrong_result(case, min(m["mean_radiance"]) > 1e7), m["mean_radiance"]


def test_zz_summary():
    """Prints the counts (run last: pytest keeps file order)."""
    s = dict(STATS, peak_mb=round(STATS["peak_kb"] / 1024, 1))
    print("\nhostile corpus: %(cases)d cases, %(errors)d clear one-line errors, %(baked)d bakes "
          "(%(repairs_counted)d with counted repairs, %(warned)d with warnings), crashes %(crashes)d, hangs %(hangs)d, "
          "NaN %(nan)d, lost files %(lost_bakes)d, wrong results at exit 0 %(wrong)d, peak memory %(peak_mb)s MB "
          "(%(peak_case)s), skipped %(skipped)d" % s)
    path = os.environ.get("IBLBAKE_CORPUS_REPORT")
    if path:
        with open(path, "w") as f:
            json.dump(s, f, indent=1)
    assert STATS["crashes"] == 0 and STATS["nan"] == 0 and STATS["lost_bakes"] == 0
    assert STATS["hangs"] == 0 and STATS["wrong"] == 0
