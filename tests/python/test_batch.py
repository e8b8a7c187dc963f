"""The CLI's batch (iblbake bake A.exr B.exr DIR/ --list FILE -o OUT): names,
the index, failures, resume, --force, shards, --jobs, the progress display,
and that one file is still today's single bake."""
import json
import os
import subprocess
import time

import numpy as np
import pytest

import iblbake_core
import pty_run

CLI = os.environ.get("IBLBAKE_CLI") or os.path.join(os.path.dirname(__file__), "..", "..", "build", "native", "iblbake")
SMALL = ["--face-size", "16", "--irradiance-size", "8", "--lut-size", "16", "--mips", "3"]


def cli(*args, cwd=None):
    return subprocess.run([CLI, *args], capture_output=True, text=True, cwd=cwd)


def world(path, seed):
    """A small lat-long EXR, different for each seed."""
    rng = np.random.default_rng(seed)
    img = rng.random((16, 32, 3), dtype=np.float32) * np.float32(1 + seed % 5)
    os.makedirs(os.path.dirname(str(path)), exist_ok=True)
    iblbake_core.write_exr(str(path), img)
    return str(path)


def index(out):
    with open(os.path.join(str(out), "index.json")) as f:
        return json.load(f)


def by_name(idx):
    return {w["name"]: w for w in idx["worlds"]}


def file_hashes(folder):
    """Every file of a bake by its sha256, as its manifest lists them."""
    with open(os.path.join(str(folder), "manifest.json")) as f:
        return {k: v["sha256"] for k, v in json.load(f)["files"].items()}


def mtimes(out):
    return {os.path.join(r, f): os.stat(os.path.join(r, f)).st_mtime_ns
            for r, _, fs in os.walk(str(out)) for f in fs if not f.startswith("index.")}


@pytest.fixture
def lib(tmp_path):
    """A folder of three worlds, two more of one name elsewhere, a broken one."""
    d = tmp_path / "lib"
    for k, name in enumerate(("alpha", "beta", "my world \u00fc")):
        world(d / (name + ".exr"), k)
    world(tmp_path / "x" / "forest.exr", 10)
    world(tmp_path / "y" / "Forest.exr", 11)
    (d / "broken.exr").write_bytes(b"not an exr\n" * 10)
    (d / "notes.txt").write_text("not a world: a folder takes images only")
    return tmp_path


def test_names_index_gallery_and_failures(lib):
    out = lib / "out"
    r = cli("bake", str(lib / "lib"), str(lib / "x" / "forest.exr"), str(lib / "y" / "Forest.exr"),
            str(lib / "missing.exr"), "-o", str(out), *SMALL)
    assert r.returncode == 1, r.stdout + r.stderr
    idx = index(out)
    names = [w["name"] for w in idx["worlds"]]
    # the folder's images sorted by name, then the files as given; notes.txt is not an image
    assert names[:4] == ["alpha", "beta", "broken", "my_world___"]
    # forest.exr and Forest.exr: one name without case, so each gets its path's hash
    assert names[4].startswith("forest-") and names[5].startswith("Forest-") and names[4][7:] != names[5][7:]
    assert names[6] == "missing"
    w = by_name(idx)
    assert idx["counts"] == {"baked": 5, "unchanged": 0, "failed": 2}
    assert w["broken"]["status"] == "failed" and "broken.exr" in w["broken"]["error"]
    assert w["missing"]["status"] == "failed" and "no such file" in w["missing"]["error"]
    assert not (out / "broken").exists() and not (out / "missing").exists()
    for name in ("alpha", "beta", "my_world___", names[4], names[5]):
        assert w[name]["status"] == "baked" and w[name]["error"] is None
        assert w[name]["preview"] == name + "/preview.png" and (out / name / "preview.png").is_file()
        with open(out / name / "manifest.json") as f:
            m = json.load(f)
        assert m["batch"] == {"content_hash": w[name]["content_hash"], "name": name}
    # the two forests are two bakes of two worlds
    assert file_hashes(out / names[4]) != file_hashes(out / names[5])
    # one line on stderr per failure, after the others were baked
    errors = [line for line in r.stderr.splitlines() if line.startswith("iblbake: error: ")]
    assert len(errors) == 2 and "broken" in errors[0] and "missing" in errors[1]
    assert "[7/7]" in r.stdout and "5 baked, 0 unchanged, 2 failed of 7 worlds" in r.stdout
    html = (out / "index.html").read_text()
    assert html.index("broken") < html.index("alpha")  # failures first
    assert 'src="alpha/preview.png"' in html and "no such file" in html


def test_resume_changed_options_and_force(lib):
    out = lib / "out"
    src = [str(lib / "lib" / "alpha.exr"), str(lib / "lib" / "beta.exr")]
    assert cli("bake", *src, "-o", str(out), *SMALL).returncode == 0
    first = index(out)
    before = mtimes(out)
    r = cli("bake", *src, "-o", str(out), *SMALL)
    assert r.returncode == 0 and "0 baked, 2 unchanged, 0 failed" in r.stdout
    assert mtimes(out) == before  # nothing rewritten
    assert [w["content_hash"] for w in index(out)["worlds"]] == [w["content_hash"] for w in first["worlds"]]
    # threads change no file: still unchanged
    assert "2 unchanged" in cli("bake", *src, "-o", str(out), *SMALL, "--threads", "1").stdout
    # a changed source is baked again, the other is not
    world(lib / "lib" / "beta.exr", 99)
    w = by_name(index(out) if cli("bake", *src, "-o", str(out), *SMALL).returncode == 0 else {})
    assert w["alpha"]["status"] == "unchanged" and w["beta"]["status"] == "baked"
    assert w["beta"]["content_hash"] != by_name(first)["beta"]["content_hash"]
    # a damaged output is baked again
    with open(out / "alpha" / "specular_0.exr", "r+b") as f:
        f.seek(100)
        f.write(b"\0\0\0\0")
    assert by_name(index(out) if cli("bake", *src, "-o", str(out), *SMALL).returncode == 0 else {})[
        "alpha"]["status"] == "baked"
    # an option that changes files: every world
    r = cli("bake", *src, "-o", str(out), *SMALL, "--rotation", "30")
    assert "2 baked, 0 unchanged" in r.stdout
    # --force bakes what is unchanged
    r = cli("bake", *src, "-o", str(out), *SMALL, "--rotation", "30", "--force")
    assert "2 baked, 0 unchanged" in r.stdout


def test_one_file_is_todays_single_bake(lib, tmp_path):
    src = str(lib / "lib" / "alpha.exr")
    out = tmp_path / "single"
    r = cli("bake", src, "-o", str(out), *SMALL)
    assert r.returncode == 0 and r.stdout.startswith("baked ")
    assert (out / "manifest.json").is_file() and not (out / "index.json").exists()
    with open(out / "manifest.json") as f:
        assert "batch" not in json.load(f)
    r = cli("bake", src, "-o", str(tmp_path / "other"), "--jobs", "2")
    assert r.returncode == 1 and "apply to a batch" in r.stderr and not (tmp_path / "other").exists()
    # a batch never writes into a single bake's folder
    r = cli("bake", src, str(lib / "lib" / "beta.exr"), "-o", str(out), *SMALL)
    assert r.returncode == 1 and "holds a single bake" in r.stderr
    # a folder without images
    (tmp_path / "empty").mkdir()
    r = cli("bake", str(tmp_path / "empty"), "-o", str(tmp_path / "none"))
    assert r.returncode == 1 and "no worlds to bake" in r.stderr and not (tmp_path / "none").exists()
    r = cli("bake", "--list", str(lib / "nolist.txt"), "-o", str(tmp_path / "none"))
    assert r.returncode == 1 and "cannot read the list file" in r.stderr
    r = cli("bake", str(lib / "lib"), "-o", str(tmp_path / "none"), "--shard", "3/3")
    assert r.returncode == 1 and "--shard must be I/N" in r.stderr


def test_list_file_shards_and_jobs_equal_a_local_run(tmp_path):
    names = []
    for k in range(7):
        world(tmp_path / "w" / ("w%d.exr" % k), k)
        names.append("w%d" % k)
    lst = tmp_path / "worlds.txt"
    lst.write_text("# the library\n" + "".join("w/w%d.exr\n" % k for k in range(7)) + "\n")
    local = tmp_path / "local"
    assert cli("bake", "--list", str(lst), "-o", str(local), *SMALL).returncode == 0
    assert [w["name"] for w in index(local)["worlds"]] == names
    farm = tmp_path / "farm"
    for i in range(3):
        r = cli("bake", "--list", str(lst), "-o", str(farm), *SMALL, "--shard", "%d/3" % i)
        assert r.returncode == 0, r.stderr
        with open(farm / ("index.%d-of-3.json" % i)) as f:
            part = json.load(f)
        assert part["shard"] == "%d/3" % i and [w["name"] for w in part["worlds"]] == names[i::3]
    assert not (farm / "index.json").exists()
    for n in names:
        assert file_hashes(farm / n) == file_hashes(local / n), n
    # the run without --shard finds everything baked and writes the whole index
    r = cli("bake", "--list", str(lst), "-o", str(farm), *SMALL)
    assert r.returncode == 0 and "0 baked, 7 unchanged" in r.stdout
    assert [w["content_hash"] for w in index(farm)["worlds"]] == [w["content_hash"] for w in index(local)["worlds"]]
    # several worlds at once: the same files
    jobs = tmp_path / "jobs"
    r = cli("bake", "--list", str(lst), "-o", str(jobs), *SMALL, "--jobs", "3", "--no-cache")
    assert r.returncode == 0 and "7 baked" in r.stdout, r.stderr
    for n in names:
        assert file_hashes(jobs / n) == file_hashes(local / n), n
    # the module gives bake_world.py the same worlds and shards
    got = iblbake_core.batch_worlds([], [str(lst)], shard="1/3")
    assert [w["name"] for w in got] == names[1::3]
    assert iblbake_core.intact_manifest(str(local / "w0"))["batch"]["name"] == "w0"
    assert iblbake_core.intact_manifest(str(tmp_path / "w")) is None


def run_on_a_terminal(args, timeout=120):
    """Runs the CLI with a pseudo-terminal as stdout and stderr; returns (code, what it printed)."""
    return pty_run.run_on_a_terminal([CLI, *args], timeout=timeout)


def test_progress_bar_on_a_terminal_and_lines_otherwise(lib):
    args = ["bake", str(lib / "lib"), "-o", str(lib / "tty"), *SMALL]
    code, text = run_on_a_terminal(args)
    assert code == 1
    # a bar redrawn in place: worlds done, the current world's stage, rate, ETA
    assert "\r[" in text and "\033[K" in text and "ETA " in text
    assert "worlds/min" in text and "/4 " in text
    assert any(s in text for s in (": hashing", ": reading", ": specular", ": writing"))
    assert "failed broken" in text  # a failure stays on screen as a line
    # not a terminal: one plain line per world, no escape codes
    r = cli(*args)
    assert "\033" not in r.stdout + r.stderr and "\r" not in r.stdout + r.stderr
    assert [line.split("] ")[1].split()[0] for line in r.stdout.splitlines() if line.startswith("[")] == [
        "unchanged", "unchanged", "failed", "unchanged"]


def test_a_signal_stops_the_batch_and_the_same_command_goes_on(tmp_path):
    for k in range(40):
        world(tmp_path / "w" / ("w%02d.exr" % k), k)
    out = tmp_path / "out"
    args = [CLI, "bake", str(tmp_path / "w"), "-o", str(out), *SMALL]
    p = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    first = p.stdout.readline() + p.stdout.readline()  # "batch: 40 worlds", then the first world's line
    assert "[1/40] baked w00" in first
    p.send_signal(2)
    rest, err = p.communicate(timeout=120)
    assert p.returncode == 130, first + rest + err
    assert "batch stopped (Interrupt)" in err
    done = index(out)["worlds"]
    assert 1 <= len(done) < 40 and all(w["status"] == "baked" for w in done)
    assert not [n for n in os.listdir(str(out)) if n.startswith(".")]  # no staging folder left
    r = cli(*args[1:])
    assert r.returncode == 0 and "%d baked, %d unchanged" % (40 - len(done), len(done)) in r.stdout


def test_the_addons_batch_core_names_shards_and_indexes_as_the_cli(lib, tmp_path):
    """core/batch.py (bake_world.py --batch without bpy): the CLI's worlds and
    names, .blend files taken from folders too, a failure kept in the index."""
    import sys
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "addon"))
    from iblbake.core import batch
    (lib / "lib" / "scene.blend").write_bytes(b"BLENDER-v300")
    items = batch.worlds([str(lib / "lib"), str(lib / "x" / "forest.exr")], shard="0/1")
    assert [w["name"] for w in items] == ["alpha", "beta", "broken", "my_world___", "scene", "forest"]
    lines = []

    def bake_one(world):
        if world["name"] == "broken":
            raise RuntimeError("cannot read it")
        return ("unchanged" if world["name"] == "beta" else "baked"), "h-" + world["name"]
    out = tmp_path / "addon-out"
    entries = batch.run(items, str(out), bake_one, log=lines.append)
    assert lines[2] == "[3/6] failed broken: cannot read it" and lines[1] == "[2/6] unchanged beta"
    idx = index(out)
    assert [(w["name"], w["status"], w["content_hash"]) for w in idx["worlds"]][:3] == [
        ("alpha", "baked", "h-alpha"), ("beta", "unchanged", "h-beta"), ("broken", "failed", None)]
    assert idx["worlds"][2]["error"] == "cannot read it" and len(entries) == 6


def test_sun_split_per_world(tmp_path):
    """--sun split in a batch: each world's folder holds its own sun.json (a
    sun found in the sky with a disc, none in the noise), each manifest says
    so, and a second run finds both unchanged (sun.json among the checked files)."""
    from test_sun import sun_sky
    img, _ = sun_sky()
    os.makedirs(str(tmp_path / "w"))
    iblbake_core.write_exr(str(tmp_path / "w" / "sky.exr"), img)
    world(tmp_path / "w" / "noise.exr", 3)
    out = tmp_path / "out"
    args = ("bake", str(tmp_path / "w"), "-o", str(out), "--sun", "split", "--face-size", "32",
            "--irradiance-size", "8", "--lut-size", "16", "--preset", "three")
    r = cli(*args)
    assert r.returncode == 0, r.stdout + r.stderr
    assert [w["status"] for w in index(out)["worlds"]] == ["baked", "baked"]
    found = {}
    for name in ("noise", "sky"):
        with open(out / name / "sun.json") as f:
            sun = json.load(f)
        with open(out / name / "manifest.json") as f:
            m = json.load(f)
        assert m["options"]["sun"] == "split" and m["sun"] == sun and "sun.json" in m["files"]
        found[name] = sun["found"]
    assert found == {"sky": True, "noise": False}
    assert (out / "sky" / "sun.gltf").is_file() and not (out / "noise" / "sun.gltf").exists()
    r = cli(*args)
    assert r.returncode == 0 and "0 baked, 2 unchanged" in r.stdout, r.stdout + r.stderr
    # without --sun the content hash differs: both baked again, without sun.json
    r = cli(*args[:4], *args[6:])
    assert "2 baked, 0 unchanged" in r.stdout and not (out / "sky" / "sun.json").exists()


def test_hostile_world_folders(lib):
    """Issue 24's protections per world: a FIFO named manifest.json neither
    hangs the check nor is replaced; a file added to a world's folder is kept
    and that world fails (the others are baked); both say why."""
    out = lib / "out"
    src = [str(lib / "lib" / "alpha.exr"), str(lib / "lib" / "beta.exr")]
    assert cli("bake", *src, "-o", str(out), *SMALL).returncode == 0
    (out / "alpha" / "notes.txt").write_text("mine")
    (out / "gamma").mkdir()
    os.mkfifo(str(out / "gamma" / "manifest.json"))
    world(lib / "lib" / "gamma.exr", 7)
    start = time.monotonic()
    r = subprocess.run([CLI, "bake", *src, str(lib / "lib" / "gamma.exr"), "-o", str(out), *SMALL, "--rotation", "10"],
                       capture_output=True, text=True, timeout=120)
    assert time.monotonic() - start < 60
    assert r.returncode == 1, r.stdout + r.stderr
    w = by_name(index(out))
    assert w["beta"]["status"] == "baked"
    assert w["alpha"]["status"] == "failed" and "notes.txt" in w["alpha"]["error"]
    assert (out / "alpha" / "notes.txt").read_text() == "mine"
    assert w["gamma"]["status"] == "failed"
    assert os.path.exists(str(out / "gamma" / "manifest.json"))


def test_the_addons_batch_overlaps_worlds_and_draws_the_bar(lib, tmp_path):
    """core/batch.py with jobs=2: bake_one (Blender's half, this thread)
    returns the bake's rest, which runs on a worker while the next world is
    prepared; at most two worlds are held; the index keeps the worlds' order
    whatever order they end in; on a terminal a bar (worlds done, the current
    world's stage, rate, ETA) with failures kept as lines, else plain lines."""
    import io
    import sys
    import threading
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "addon"))
    from iblbake.core import batch
    items = [{"source": "/x/w%d.exr" % k, "name": "w%d" % k} for k in range(6)]
    lock = threading.Lock()
    held, most, overlapped = [0], [0], threading.Event()
    release = {k: threading.Event() for k in range(6)}

    def bake_one(world):
        k = int(world["name"][1:])
        with lock:
            held[0] += 1
            most[0] = max(most[0], held[0])
        if k == 3:
            with lock:
                held[0] -= 1
            raise RuntimeError("no pixels")

        def finish(progress, say):
            progress("specular", 0.5)
            if k == 2:
                say("replaced the earlier bake in w2: a note")
            if k == 0:  # world 0 waits until world 1 has started beside it: they overlap
                release[0].wait(30)
            if k == 1:
                overlapped.set()
                release[0].set()
            with lock:
                held[0] -= 1
            return ("unchanged" if k == 4 else "baked"), "h%d" % k
        return finish

    for tty in (False, True):
        held[0], most[0] = 0, 0
        overlapped.clear()
        release[0].clear()
        lines, bar = [], io.StringIO()
        out = tmp_path / ("tty" if tty else "plain")
        entries = batch.run(items, str(out), bake_one, log=lines.append, jobs=2, tty=tty, stream=bar)
        assert overlapped.is_set() and most[0] <= 2, most
        assert [(e["name"], e["status"]) for e in entries] == [
            ("w0", "baked"), ("w1", "baked"), ("w2", "baked"), ("w3", "failed"), ("w4", "unchanged"),
            ("w5", "baked")]
        assert [w["name"] for w in index(out)["worlds"]] == ["w0", "w1", "w2", "w3", "w4", "w5"]
        text = bar.getvalue()
        if tty:
            assert not lines and "\r[" in text and "\033[K" in text and "/6" in text and "ETA " in text
            assert "worlds/min" in text
            assert "failed w3: no pixels\n" in text  # a failure stays as a line
            assert "\r\033[Kreplaced the earlier bake in w2: a note\n" in text  # a bake's note too
        else:
            assert text == "" and len(lines) == 7 and "\033" not in "".join(lines)
            assert lines[0].startswith("[1/6] baked w1") or lines[0].startswith("[1/6] baked w0"), lines
            assert any(line.startswith("[") and "failed w3: no pixels" in line for line in lines)
            assert "replaced the earlier bake in w2: a note" in lines
    d = batch.Display(10, False, clock=iter([0.0, 60.0]).__next__)
    d.done, d.current, d.stage_text, d.fraction = 3, "forest", "specular", 0.4
    assert d.bar() == "[#######.................] 3/10 forest: specular 40% | 3.0 worlds/min | ETA 2:20 | 1:00"
    d.close()


def test_the_addons_batch_holds_at_most_jobs_worlds_and_times_each_where_it_ends(tmp_path):
    """A world's pixels (what its finish holds) are let go once it is baked,
    before a second world past `jobs` is read (jobs 1 and 2), and a world's
    seconds end when its bake ends, not when the main thread, busy reading
    the next world, collects it."""
    import sys
    import threading
    import weakref
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "addon"))
    from iblbake.core import batch
    items = [{"source": "/x/w%d.exr" % k, "name": "w%d" % k} for k in range(5)]

    class Pixels:
        pass

    for jobs in (1, 2):
        alive, most = set(), [0]
        lock = threading.Lock()

        def bake_one(world):
            end = time.monotonic() + 2.0  # a worker lets go of its finish just after its future is done
            while time.monotonic() < end:
                with lock:
                    if len(alive) < jobs:
                        break
                time.sleep(0.005)
            k = int(world["name"][1:])
            pixels = Pixels()
            with lock:
                alive.add(k)
                most[0] = max(most[0], len(alive))
            weakref.finalize(pixels, lambda k=k: alive.discard(k))
            time.sleep(0.3 if k == 1 else 0.0)  # reading world 1 is slow

            def finish(progress, say):
                assert isinstance(pixels, Pixels)
                time.sleep(0.05)
                return "baked", "h%d" % k
            return finish

        entries = batch.run(items, str(tmp_path / ("j%d" % jobs)), bake_one, log=lambda line: None, jobs=jobs)
        assert [e["status"] for e in entries] == ["baked"] * 5
        assert most[0] <= jobs, (jobs, most[0])
        assert entries[0]["seconds"] < 0.25, entries[0]  # world 0 ended while world 1 was being read
