"""docs/farm.md's sbatch script on a real Slurm (one node, started here as
root by slurm_cluster.py): a job array of four shards over a dozen small
worlds, then the gathering job; the shards' folders equal a local run's.
Skipped, with the reason, without root or without Debian's munge, slurmctld,
slurmd and slurm-client (scripts/install_deps.sh installs them)."""
import json
import os
import re
import subprocess
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import slurm_cluster  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
FARM_MD = os.path.join(HERE, "..", "..", "docs", "farm.md")
CLI = os.environ.get("IBLBAKE_CLI") or os.path.join(HERE, "..", "..", "build", "native", "iblbake")
OPTIONS = "--face-size 16 --irradiance-size 8 --lut-size 16 --mips 3"
SHARDS = 4


def doc_blocks():
    """docs/farm.md's code blocks: (language, text)."""
    with open(FARM_MD) as f:
        return re.findall(r"```(\w*)\n(.*?)```", f.read(), re.S)


def array_script():
    found = [text for lang, text in doc_blocks() if lang == "bash" and "#SBATCH" in text]
    assert len(found) == 1, "docs/farm.md must hold one ```bash block with #SBATCH lines"
    return found[0]


def gather_command():
    """The documented gathering step's --wrap command."""
    for _, text in doc_blocks():
        m = re.search(r"--wrap '([^']*)'", text)
        if m:
            return m.group(1)
    raise AssertionError("docs/farm.md has no sbatch --dependency ... --wrap '...' step")


def make_worlds(folder, n):
    import iblbake_core
    os.makedirs(folder)
    paths = []
    for k in range(n):
        rng = np.random.default_rng(100 + k)
        img = rng.random((16, 32, 3), dtype=np.float32) * np.float32(1 + k % 4)
        p = os.path.join(folder, "world%02d.exr" % k)
        iblbake_core.write_exr(p, img)
        paths.append(p)
    return paths


def files_of(folder):
    with open(os.path.join(folder, "manifest.json")) as f:
        return {k: v["sha256"] for k, v in json.load(f)["files"].items()}


@pytest.fixture
def cluster(tmp_path):
    d = tmp_path / "slurm"
    d.mkdir()
    try:
        c = slurm_cluster.SlurmCluster(str(d)).__enter__()
    except slurm_cluster.Unavailable as e:
        pytest.skip("no Slurm cluster here: %s" % e)
    yield c
    c.stop()


def test_sbatch_array_shards_equal_a_local_run(cluster, tmp_path):
    worlds = make_worlds(str(tmp_path / "worlds"), 12)
    lst = tmp_path / "library.txt"
    lst.write_text("".join(os.path.relpath(p, str(tmp_path)) + "\n" for p in worlds))
    local = tmp_path / "local"
    r = subprocess.run([CLI, "bake", "--list", str(lst), "-o", str(local), *OPTIONS.split()],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr

    script = tmp_path / "iblbake-array.sh"
    script.write_text(array_script())
    out = tmp_path / "farm"
    env = dict(cluster.env, LIST=str(lst), OUT=str(out), IBLBAKE=os.path.abspath(CLI), IBLBAKE_OPTIONS=OPTIONS)
    work = tmp_path / "logs"
    work.mkdir()
    sub = subprocess.run(["sbatch", "--parsable", "--array=0-%d" % (SHARDS - 1), str(script)], env=env, cwd=str(work),
                         capture_output=True, text=True)
    assert sub.returncode == 0, sub.stderr + cluster.tail()
    array = sub.stdout.strip().split(";")[0]
    gather = subprocess.run(["sbatch", "--parsable", "--dependency=afterany:" + array, "--job-name=iblbake-index",
                             "--output=iblbake-index.log", "--wrap", gather_command()],
                            env=env, cwd=str(work), capture_output=True, text=True)
    assert gather.returncode == 0, gather.stderr
    finished = cluster.wait_for_jobs(300)
    logs = {name: (work / name).read_text() for name in sorted(os.listdir(str(work)))}
    assert finished, "jobs still queued after 300 s:\n%s\n%s" % (cluster.run("squeue").stdout, logs)

    # each task baked its shard: worlds i, i + 4, i + 8 of the list
    names = ["world%02d" % k for k in range(12)]
    for i in range(SHARDS):
        log = logs.get("iblbake-%s_%d.log" % (array, i), "")
        assert "batch: 3 baked, 0 unchanged, 0 failed of 3 worlds" in log, logs
        with open(out / ("index.%d-of-%d.json" % (i, SHARDS))) as f:
            part = json.load(f)
        assert [w["name"] for w in part["worlds"]] == names[i::SHARDS]
        assert all(w["status"] == "baked" for w in part["worlds"])
    # the union of the shards is the local run, file for file
    assert sorted(p for p in os.listdir(str(out)) if not p.startswith("index.")) == names
    for n in names:
        assert files_of(str(out / n)) == files_of(str(local / n)), n
    # the gathering job found everything baked and wrote the whole index
    assert "batch: 0 baked, 12 unchanged, 0 failed of 12 worlds" in logs["iblbake-index.log"], logs
    with open(out / "index.json") as f:
        idx = json.load(f)
    with open(local / "index.json") as f:
        ref = json.load(f)
    assert [(w["name"], w["content_hash"]) for w in idx["worlds"]] == [(w["name"], w["content_hash"])
                                                                      for w in ref["worlds"]]
    assert (out / "index.html").is_file()
