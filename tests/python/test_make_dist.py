"""scripts/wheel/make_dist.py's pieces (scripts/package.sh writes dist/ with
them): the self-containment check of a module, the wheel's files and its
RECORD, the extension manifest. Real wheels are read by pip and python3-wheel
and proven in foreign chroots by scripts/check_wheels.sh."""
import base64
import hashlib
import os
import sys
import zipfile

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "scripts", "wheel"))
import make_dist  # noqa: E402

GOOD = {"needed": ["libm.so.6", "libc.so.6", "ld-linux-x86-64.so.2", "libpthread.so.0", "libdl.so.2"],
        "glibc": "2.25", "versions": {"libc.so.6": ["GLIBC_2.2.5", "GLIBC_2.25"]},
        "exports": ["PyInit_iblbake_core"], "runpath": False}


def test_a_module_needing_glibc_alone_passes():
    assert make_dist.check_module("m.so", GOOD) == []


@pytest.mark.parametrize("change,words", [
    ({"needed": GOOD["needed"] + ["libtbb.so.12"]}, "libtbb.so.12"),
    ({"versions": {"libstdc++.so.6": ["GLIBCXX_3.4.29"]}}, "GLIBCXX_3.4.29"),
    ({"exports": ["PyInit_iblbake_core", "_ZN7Imf_3_17Header"]}, "exports"),
    ({"runpath": True}, "RPATH"),
])
def test_what_would_tie_a_module_to_the_build_machine_is_refused(change, words):
    why = make_dist.check_module("m.so", dict(GOOD, **change))
    assert len(why) == 1 and words in why[0] and why[0].startswith("m.so: ")


def test_wheel_record_lists_every_file_with_its_hash(tmp_path):
    module = tmp_path / "iblbake_core.cpython-313-x86_64-linux-gnu.so"
    module.write_bytes(b"\x7fELF not really")
    name = make_dist.make_wheel(str(tmp_path), str(module), "1.2.3", "3", "13", "manylinux_2_25_x86_64", "abc")
    assert name == "iblbake_core-1.2.3-cp313-cp313-manylinux_2_25_x86_64.whl"
    with zipfile.ZipFile(tmp_path / name) as z:
        files = {n: z.read(n) for n in z.namelist()}
        assert all(i.date_time == (1980, 1, 1, 0, 0, 0) for i in z.infolist())  # reproducible
    record = files["iblbake_core-1.2.3.dist-info/RECORD"].decode().splitlines()
    listed = {}
    for line in record:
        path, digest, size = line.rsplit(",", 2)
        listed[path] = (digest, size)
    assert set(listed) == set(files)
    for path, data in files.items():
        if path.endswith("RECORD"):
            assert listed[path] == ("", "")
            continue
        want = "sha256=" + base64.urlsafe_b64encode(hashlib.sha256(data).digest()).rstrip(b"=").decode()
        assert listed[path] == (want, str(len(data)))
    wheel = files["iblbake_core-1.2.3.dist-info/WHEEL"].decode()
    assert "Root-Is-Purelib: false" in wheel and "Tag: cp313-cp313-manylinux_2_25_x86_64" in wheel
    assert "Requires-Python: >=3.13,<3.14" in files["iblbake_core-1.2.3.dist-info/METADATA"].decode()


def test_extension_manifest_names_the_platform_and_the_wheels():
    import tomllib
    with open(os.path.join(HERE, "..", "..", "addon", "iblbake", "blender_manifest.toml")) as f:
        text = f.read()
    m = tomllib.loads(make_dist.extension_manifest(text, ["a-1-cp311-cp311-x.whl", "a-1-cp313-cp313-x.whl"]))
    assert m["platforms"] == ["linux-x64"]
    assert m["wheels"] == ["./wheels/a-1-cp311-cp311-x.whl", "./wheels/a-1-cp313-cp313-x.whl"]
    assert m["id"] == "iblbake"
