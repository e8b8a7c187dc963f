

# --- E12: a black world; E13: messages ------------------------------------------------------------

def test_e12_a_black_world_warns(tmp_path):
    src = write(tmp_path / "s.exr", corpus.exr_bytes(value=0.0))
    r = bake(src, tmp_path / "out")
    assert r.returncode == 0, r.stderr
    assert any("black" in w for w in manifest(tmp_path / "out")["warnings"])
    assert "iblbake: warning: the world is black" in r.stderr


def test_e13_manifest_extra_errors_are_one_line():
    r = subprocess.run([sys.executable, "-c", "import iblbake_core as ib, numpy as np\n"
                        "try:\n    ib.bake(np.ones((32, 64, 3), np.float32), None, face_size=8, "
                        "manifest_extra={'a': object()})\nexcept ValueError as e:\n    print(repr(str(e)))"],
                       capture_output=True, text=True, env=dict(os.environ))
    assert r.returncode == 0 and "manifest_extra" in r.stdout, r.stdout + r.stderr
    assert "Traceback" not in r.stdout and "\\n" not in r.stdout.strip(), r.stdout


@pytest.mark.parametrize("name, data, words", [
    ("xyz.hdr", corpus.hdr_bytes(64, 32).replace(b"32-bit_rle_rgbe", b"32-bit_rle_xyze"), "XYZ"),
    ("texture.dds", b"DDS " + bytes(300), "DDS"),
])
def test_e13_unreadable_kinds_are_named(tmp_path, name, data, words):
    src = write(tmp_path / name, data)
    one_line_error(bake(src, tmp_path / "out"), str(src), words)


def test_e13_a_full_disk_names_the_output_folder_and_the_reason(tmp_path):
    if os.geteuid() != 0:
        pytest.skip("a small tmpfs needs root to mount")
    mnt = tmp_path / "mnt"
    mnt.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=600k", "tmpfs", str(mnt)], capture_output=True).returncode:
        pytest.skip("mount -t tmpfs is not permitted here")
    try:
        src = write(tmp_path / "s.exr", corpus.exr_bytes())
        r = bake(src, mnt / "out", "--face-size", "128", "--preset", "filament,khronos:rgba32f,bevy")
        line = one_line_error(r)
        assert ".iblbake-" not in line and str(mnt / "out") in line, line
        assert "No space left on device" in line, line
    finally:
        subprocess.run(["umount", str(mnt)], capture_output=True)
