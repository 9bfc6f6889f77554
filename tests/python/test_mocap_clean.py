"""pytest suite of the mocap_clean module (python/). Run by CTest with PYTHONPATH=build/python and
MOCAP_CLI=build/app/mocap-clean; the tests on the shared CMU clips skip when
../shared/data/bvh is absent."""
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import h5py
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import mocap_clean as mc

REPO = Path(__file__).resolve().parents[2]
SHARED = REPO / ".." / "shared" / "data" / "bvh"
CLI = Path(os.environ.get("MOCAP_CLI", REPO / "build" / "app" / "mocap-clean"))

# Small clips first: the CLI runs once per method and clip.
CLIPS = ["cmu_mb_02_03.bvh", "cmu_mb_02_01.bvh"]

needs_clips = pytest.mark.skipif(
    not SHARED.is_dir(), reason=f"shared clips not found at {SHARED} (../shared/data/bvh)")
needs_cli = pytest.mark.skipif(not CLI.exists(), reason=f"mocap-clean binary not found at {CLI}")


def bits(a):
    """The array's bit pattern: equality of these is bit-identity (NaN and -0 included)."""
    a = np.ascontiguousarray(a)
    return a.view(np.uint32 if a.dtype == np.float32 else np.uint64)


def run_cli(*args, check=True):
    return subprocess.run([str(CLI), *map(str, args)], capture_output=True, text=True, check=check)


def read_library(path):
    """Every clip of a library file: {clip path: (rotations, translations)} (h5py)."""
    out = {}
    with h5py.File(path, "r") as f:
        def visit(name, obj):
            if isinstance(obj, h5py.Group) and "rotations" in obj:
                out[name] = (obj["rotations"][()], obj["translations"][()])
        f["clips"].visititems(visit)
    return out


def smooth_curve(frames=60, joints=3, seed=0):
    """Unit quaternions (F, J, 4) wxyz of a smooth motion plus small noise, float32."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 2, frames)[:, None, None]
    axis = rng.normal(size=(1, joints, 3))
    rv = np.sin(t * (1 + np.arange(joints))[None, :, None]) * axis * 0.5
    rv = rv + rng.normal(scale=0.01, size=rv.shape)
    xyzw = Rotation.from_rotvec(rv.reshape(-1, 3)).as_quat()
    wxyz = np.concatenate([xyzw[:, 3:], xyzw[:, :3]], axis=1)
    return wxyz.reshape(frames, joints, 4).astype(np.float32)


# Each method with parameters that are not all defaults (and the defaults themselves), as
# (module call, CLI options).
CASES = [
    ("bof", {}, []),
    ("bof", {"sigma_t": 2.0, "sigma_g": 0.3, "iterations": 3, "pops": "repair"},
     ["--sigma-t", "2", "--sigma-g", "0.3", "--iterations", "3", "--pops", "repair"]),
    ("bof", {"sigma_t": 0.0, "sigma_g": 0.0}, ["--sigma-t", "0", "--sigma-g", "0"]),
    ("nlpm", {}, []),
    ("nlpm", {"h": 0.05, "nlpm_range": "auto", "search_radius": 6, "patch_radius": 3},
     ["--h", "0.05", "--nlpm-range", "auto", "-K", "6", "-P", "3"]),
    ("gaussian", {"sigma_t": 1.5}, ["--sigma-t", "1.5"]),
    ("butterworth", {"order": 3, "cutoff": 8.0}, ["--order", "3", "--cutoff", "8"]),
    ("moving_mean", {"passes": 2}, ["--passes", "2"]),
    ("kalman", {}, []),
    ("auto", {}, []),
    ("auto", {"split_impossible": True, "boundary": "hold"},
     ["--split-impossible", "--boundary", "hold"]),
]


@needs_clips
@needs_cli
@pytest.mark.parametrize("clip", CLIPS)
def test_filters_are_bit_identical_to_the_cli(tmp_path, clip):
    source = SHARED / clip
    library = tmp_path / "lib.h5"
    run_cli("import", source, "-o", library, "--compression", "none", "--no-progress")
    (imported_rot, imported_trans), = read_library(library).values()
    motion = mc.read_bvh(source)
    # read_bvh is the reader `import` runs.
    assert np.array_equal(bits(motion.rotations), bits(imported_rot))
    assert np.array_equal(bits(motion.translations), bits(imported_trans))

    for i, (method, kwargs, options) in enumerate(CASES):
        out = tmp_path / f"out{i}.h5"
        run_cli("filter", library, "-o", out, "--compression", "none", "--no-progress",
                "--method", method.replace("_", "-"), *options)
        (cli_rot, cli_trans), = read_library(out).values()
        result = getattr(mc, method)(motion, **kwargs)
        if method == "auto":
            result, info = result
            assert info["method"] in ("bof", "nlpm")
        assert np.array_equal(bits(result.rotations), bits(cli_rot)), (method, kwargs)
        assert np.array_equal(bits(result.translations), bits(cli_trans)), (method, kwargs)
        # The input Motion is left as it came (the engine filtered its own copy).
        assert np.array_equal(bits(motion.rotations), bits(imported_rot))


@needs_clips
@needs_cli
def test_clean_bvh_text_is_identical_to_the_cli(tmp_path):
    """`mocap-clean clean` end to end (BVH in, BVH out) against read_bvh + bof + format_bvh."""
    source = SHARED / CLIPS[0]
    run_cli("clean", source, "-o", tmp_path / "out", "--method", "bof", "--sigma-t", "1.5",
            "--no-progress")
    cli_text = (tmp_path / "out" / CLIPS[0]).read_text()
    cleaned = mc.bof(mc.read_bvh(source), sigma_t=1.5)
    assert mc.format_bvh(cleaned) == cli_text
    mc.write_bvh(cleaned, tmp_path / "module.bvh")
    assert (tmp_path / "module.bvh").read_text() == cli_text


@needs_clips
def test_arrays_and_motion_give_the_same_bits_for_any_thread_count():
    motion = mc.read_bvh(SHARED / CLIPS[0])
    from_motion = mc.nlpm(motion, threads=1)
    rot, trans = mc.nlpm(np.array(motion.rotations), translations=np.array(motion.translations),
                         frame_time=motion.frame_time, threads=2)
    # Bare arrays: every joint's translations are filtered; compare the rotations (nlpm's
    # weights come from rotations only) and the root, the one joint with position channels.
    assert np.array_equal(bits(rot), bits(from_motion.rotations))
    assert np.array_equal(bits(trans[:, 0]), bits(from_motion.translations[:, 0]))
    # float64 in, float64 out: the same float32 engine, widened.
    rot64 = mc.nlpm(motion.rotations.astype(np.float64), frame_time=motion.frame_time)
    assert rot64.dtype == np.float64
    assert np.array_equal(rot64.astype(np.float32), from_motion.rotations)


def test_scipy_rotation_round_trip():
    wxyz = smooth_curve()
    xyzw = wxyz[..., [1, 2, 3, 0]]
    # scipy's order in, scipy's order out: the same bits as the engine's order.
    filtered_xyzw = mc.bof(np.ascontiguousarray(xyzw), scalar_first=False)
    filtered_wxyz = mc.bof(wxyz)
    assert np.array_equal(bits(filtered_xyzw), bits(filtered_wxyz[..., [1, 2, 3, 0]]))
    # Through scipy and back: Rotation keeps unit quaternions (float64), the module takes them.
    r = Rotation.from_quat(filtered_xyzw.reshape(-1, 4).astype(np.float64))
    back = r.as_quat().reshape(filtered_xyzw.shape)
    again = mc.bof(back, scalar_first=False)
    assert again.dtype == np.float64 and again.shape == back.shape
    # The metrics agree with scipy's geodesic angle (our d is the full rotation angle).
    noisy = mc.add_gaussian_noise(wxyz, sigma=0.02, seed=3)
    ra = Rotation.from_quat(wxyz[..., [1, 2, 3, 0]].reshape(-1, 4).astype(np.float64))
    rb = Rotation.from_quat(noisy[..., [1, 2, 3, 0]].reshape(-1, 4).astype(np.float64))
    angles = (ra.inv() * rb).magnitude()
    assert mc.rmse(noisy, wxyz) == pytest.approx(np.sqrt(np.mean(angles ** 2)), rel=1e-4)


def test_bvh_euler_channels_match_scipy():
    # BVH rotation channels are intrinsic rotations in channel order (here Z, X, Y), in degrees.
    text = """HIERARCHY
ROOT Hips
{
\tOFFSET 0 0 0
\tCHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
\tJOINT Chest
\t{
\t\tOFFSET 0 10 0
\t\tCHANNELS 3 Zrotation Xrotation Yrotation
\t\tEnd Site
\t\t{
\t\t\tOFFSET 0 5 0
\t\t}
\t}
}
MOTION
Frames: 2
Frame Time: 0.01
1 2 3 10 20 30 -40 50 60
4 5 6 15 25 35 -45 55 65
"""
    m = mc.parse_bvh(text)
    values = np.array([[10, 20, 30, -40, 50, 60], [15, 25, 35, -45, 55, 65]], float)
    expected = Rotation.from_euler("ZXY", values.reshape(-1, 3), degrees=True).as_quat()
    got = m.quaternions(scalar_first=False).reshape(-1, 4)
    sign = np.sign(np.sum(got * expected, axis=1))[:, None]
    np.testing.assert_allclose(got, sign * expected, atol=1e-6)
    assert m.skeleton.joint_names == ["Hips", "Chest"]
    assert m.skeleton.parents == [-1, 0]
    assert m.frame_time == 0.01
    np.testing.assert_array_equal(m.translations[:, 0], [[1, 2, 3], [4, 5, 6]])
    # Forward kinematics: Chest sits 10 up in the rotated root frame.
    positions, sites = mc.forward_kinematics(m, end_sites=True)
    root = Rotation.from_euler("ZXY", values[:, :3], degrees=True)
    np.testing.assert_allclose(positions[:, 1], m.translations[:, 0] + root.apply([0, 10, 0]),
                               atol=1e-4)
    assert sites.shape == (2, 1, 3)


def test_position_metrics_on_known_tracks():
    truth = np.zeros((10, 2, 3), np.float32)
    truth[:, 0, 0] = np.arange(10)  # constant velocity: no jitter
    result = truth.copy()
    result[:, 1, 1] = 3.0           # one of two points off by 3 everywhere
    assert mc.mpjpe(result, truth) == pytest.approx(1.5)
    assert mc.mpjpe(result, truth, first=2, last=5) == pytest.approx(1.5)
    assert mc.jitter(truth) == 0.0
    bumped = truth.copy()
    bumped[5, 0, 1] = 1.0           # second differences 1, -2, 1 at t = 4, 5, 6
    assert mc.jitter(bumped) == pytest.approx(np.sqrt(6 / (8 * 2)))
    assert mc.acceleration_error(bumped, truth) == pytest.approx(np.sqrt(6 / (8 * 2)))
    with pytest.raises(ValueError, match="differ in shape"):
        mc.mpjpe(result, truth[:5])


def test_errors_carry_the_cli_messages():
    good = smooth_curve(frames=20, joints=2)
    with pytest.raises(ValueError, match=r"rotations must have shape \(F, J, 4\), got \(20, 2, 3\)"):
        mc.bof(good[..., :3])
    nan = good.copy()
    nan[3, 1, 2] = np.nan  # frames count from 1 in messages, as in BVH errors
    with pytest.raises(ValueError, match=r"^NaN in rotations at frame 4, joint '1'$"):
        mc.bof(nan)
    long = good.copy()
    long[5, 0] *= 2
    with pytest.raises(ValueError,
                       match=r"^rotation at frame 6, joint '0' is not a unit quaternion \(norm 2\)$"):
        mc.gaussian(long)
    # The kernel-level functions check values with the same words as the filters (the CLI's).
    for bad in (nan, long):
        with pytest.raises(ValueError) as from_filter:
            mc.bof(bad)
        for call in (mc.repair_pops, mc.classify_joints, mc.estimate_noise, mc.add_gaussian_noise,
                     mc.make_continuous):
            with pytest.raises(ValueError) as from_kernel:
                call(bad)
            assert str(from_kernel.value) == str(from_filter.value), call.__name__
    with pytest.raises(ValueError, match="translations must have the shape of rotations"):
        mc.bof(good, translations=np.zeros((20, 3, 3), np.float32))
    with pytest.raises(ValueError, match="frame_time must be a finite number > 0"):
        mc.bof(good, frame_time=0.0)
    with pytest.raises(TypeError):
        mc.bof("not an array")
    with pytest.raises(ValueError, match="inplace=True needs a writable C-contiguous float32"):
        mc.repair_pops(good.astype(np.float64), inplace=True)
    with pytest.raises(ValueError, match="differ in shape"):
        mc.psnr(good, good[:10])
    with pytest.raises(RuntimeError, match="nope.bvh"):
        mc.read_bvh("/nonexistent/nope.bvh")
    with pytest.raises(ValueError, match=r"<string>:\d+:"):
        mc.parse_bvh("HIERARCHY\nROOT a\n{\n")


@needs_cli
@pytest.mark.parametrize("call, options", [
    (lambda x: mc.bof(x, sigma_t=-1.0), ["--method", "bof", "--sigma-t=-1"]),
    (lambda x: mc.bof(x, iterations=0), ["--method", "bof", "--iterations", "0"]),
    (lambda x: mc.bof(x, kernel="box"), ["--method", "bof", "--kernel", "box"]),
    (lambda x: mc.butterworth(x, order=9), ["--method", "butterworth", "--order", "9"]),
    (lambda x: mc.nlpm(x, nlpm_range=-2.0), ["--method", "nlpm", "--nlpm-range=-2"]),
    (lambda x: mc.nlpm(x, space="euler"), ["--method", "nlpm", "--space", "euler"]),
    (lambda x: mc.auto(x, pops="always"), ["--method", "auto", "--pops", "always"]),
    (lambda x: mc.kalman(x, kalman_lambda=1e30), ["--method", "kalman", "--kalman-lambda", "1e30"]),
    (lambda x: mc.gaussian(x, threads=-1), ["--method", "gaussian", "--threads=-1"]),
])
def test_bad_parameters_raise_the_cli_message(tmp_path, call, options):
    clip = tmp_path / "a.bvh"
    clip.write_text("HIERARCHY\nROOT a\n{\nOFFSET 0 0 0\nCHANNELS 3 Zrotation Xrotation Yrotation\n"
                    "End Site\n{\nOFFSET 0 1 0\n}\n}\nMOTION\nFrames: 1\nFrame Time: 0.01\n0 0 0\n")
    cli = run_cli("clean", clip, "-o", tmp_path / "out", *options, check=False)
    assert cli.returncode != 0
    with pytest.raises(ValueError) as error:
        call(smooth_curve(frames=10, joints=1))
    message = str(error.value)
    assert message and message in cli.stderr, (message, cli.stderr)


def test_contiguous_float32_input_is_not_copied():
    a = smooth_curve()
    pointer = a.__array_interface__["data"][0]
    before = mc._input_copies()
    mc.psnr(a, a)
    mc.rmse(a, a)
    mc.estimate_noise(a)
    mc.classify_joints(a)
    mc.angular_speed(a, 0)
    assert mc._input_copies() == before
    # In place: the kernels write the caller's own memory.
    noisy = a.copy()
    returned = mc.add_gaussian_noise(noisy, sigma=0.01, inplace=True)
    assert returned.__array_interface__["data"][0] == noisy.__array_interface__["data"][0]
    assert not np.array_equal(noisy, a)
    repaired, info = mc.repair_pops(noisy, mode="repair", inplace=True)
    assert np.shares_memory(repaired, noisy)
    assert a.__array_interface__["data"][0] == pointer
    # float64, strided or scalar-last inputs are converted (and counted).
    mc.psnr(a.astype(np.float64), a)
    assert mc._input_copies() == before + 1
    mc.psnr(a[:, ::2], a[:, ::2])
    assert mc._input_copies() == before + 3
    # A Motion's tensors are views of its own memory: no copy either way.
    m = mc.Motion(mc.Skeleton(["a", "b", "c"], [-1, 0, 1], np.zeros((3, 3)),
                              ["Zrotation Xrotation Yrotation"] * 3), a)
    assert np.shares_memory(m.rotations, m.rotations)
    m.rotations[0, 0] = [1, 0, 0, 0]
    assert np.array_equal(m.rotations[0, 0], [1, 0, 0, 0])
    # Results own the engine's buffer (handed over, not copied).
    out = mc.bof(a)
    assert out.dtype == np.float32 and not out.flags["OWNDATA"] and out.base is not None


def test_pops_noise_and_classification():
    clean = smooth_curve(frames=200, joints=4)
    clean[:, 3] = [1, 0, 0, 0]  # a constant (uncaptured) joint
    popped, count = mc.add_impulse_noise(clean, rate=0.02, seed=5)
    assert count > 0
    classes = [j["class"] for j in mc.classify_joints(popped)]
    assert classes[3] == "constant"
    repaired, info = mc.repair_pops(popped, frame_time=1 / 120)
    assert info["repaired"] and sum(info["pops"]) > 0 and info["garbage"][3] == 1
    assert mc.psnr(repaired, clean) > mc.psnr(popped, clean) + 10
    # Same seed, same noise; the estimate sees gaussian noise of about its sigma.
    still = np.repeat(clean[:1], 400, axis=0)
    moving = smooth_curve(frames=400, joints=4, seed=1)
    n1 = mc.add_gaussian_noise(moving, sigma=0.03, seed=9)
    n2 = mc.add_gaussian_noise(moving, sigma=0.03, seed=9)
    assert np.array_equal(bits(n1), bits(n2))
    sigma, moving_joints = mc.estimate_noise(n1)
    assert moving_joints == 4 and 0.025 < sigma < 0.035
    assert mc.estimate_noise(still) == (0.0, 0)
    # auto says what it chose, for this noise level bof with one pass (engine/clip/filter_settings.hpp,
    # automatic_smoothing: one pass up to 0.09 rad, sigma_g = 4 sigma_hat).
    result, info = mc.auto(n1)
    assert info["method"] == "bof" and info["noise_sigma"] == pytest.approx(sigma)
    assert info["parameters"]["iterations"] == 1
    assert info["parameters"]["sigma_g"] == pytest.approx(4 * sigma)
    assert mc.psnr(result, moving) > mc.psnr(n1, moving)


def test_gil_is_released_while_the_engine_runs():
    data = smooth_curve(frames=20000, joints=31)  # about 0.2 s of nlpm on one thread
    ticks = []
    done = threading.Event()

    def ticker():
        while not done.is_set():
            ticks.append(time.perf_counter())
            time.sleep(0.001)

    t = threading.Thread(target=ticker)
    t.start()
    time.sleep(0.01)
    start = time.perf_counter()
    mc.nlpm(data, h=0.02, threads=1)
    end = time.perf_counter()
    done.set()
    t.join()
    during = [x for x in ticks if start < x < end]
    # Held GIL: the ticker could not run during the call at all (it ticks every ~1 ms).
    assert end - start > 0.02, "the call was too short to tell"
    assert len(during) >= 3, (end - start, len(during))


def test_every_function_has_a_docstring():
    for name in dir(mc):
        obj = getattr(mc, name)
        if callable(obj) and not name.startswith("__"):
            assert obj.__doc__ and len(obj.__doc__) > 40, name


@needs_clips
def test_the_readme_example_runs_as_written_and_prints_what_the_readme_says(tmp_path):
    readme = (REPO / "README.md").read_text()
    section = readme[readme.index("\n## Python\n"):]
    code = section[section.index("```python\n") + 10:section.index("```\n", section.index("```python"))]
    printed = section[section.index("It prints"):]
    printed = printed[printed.index("\n\n") + 2:printed.index("\n\n", printed.index("\n\n") + 2)]
    expected = [line[4:] for line in printed.splitlines()]
    # Run from a folder whose ../shared is the real one, as from the repository root.
    work = tmp_path / "repo"
    work.mkdir()
    (tmp_path / "shared").symlink_to((REPO / ".." / "shared").resolve())
    (work / "example.py").write_text(code)
    env = dict(os.environ, PYTHONPATH=str(Path(mc.__file__).parent))
    run = subprocess.run([sys.executable, "example.py"], cwd=work, env=env, capture_output=True,
                         text=True, check=True)
    assert run.stdout.splitlines() == expected
    assert mc.read_bvh(work / "cleaned.bvh").frames == mc.read_bvh(SHARED / "cmu_mb_02_01.bvh").frames


FREED_BLOCK_PROBE = """
import ctypes
import mocap_clean
class MallInfo2(ctypes.Structure):
    _fields_ = [(n, ctypes.c_size_t) for n in ("arena", "ordblks", "smblks", "hblks", "hblkhd",
                                                 "usmblks", "fsmblks", "uordblks", "fordblks",
                                                 "keepcost")]
libc = ctypes.CDLL(None)
libc.malloc.restype = ctypes.c_void_p
libc.free.argtypes = [ctypes.c_void_p]
libc.mallinfo2.restype = MallInfo2
block = libc.malloc(8 << 20)
libc.free(block)
print(libc.mallinfo2().fordblks)
"""


@pytest.mark.parametrize("host_allocator", [False, True])
def test_import_keeps_freed_blocks_for_reuse_unless_told_not_to(host_allocator):
    # As mocap-clean: an 8 MB block freed stays in the heap (free bytes >= 8 MB) for the next call
    # instead of being unmapped; MOCAP_CLEAN_HOST_ALLOCATOR=1 leaves glibc's defaults (unmapped).
    env = dict(os.environ)
    env.pop("MOCAP_CLEAN_HOST_ALLOCATOR", None)
    if host_allocator:
        env["MOCAP_CLEAN_HOST_ALLOCATOR"] = "1"
    out = subprocess.run([sys.executable, "-c", FREED_BLOCK_PROBE], env=env, capture_output=True,
                         text=True, check=True)
    free_bytes = int(out.stdout.strip())
    if host_allocator:
        assert free_bytes < 8 << 20
    else:
        assert free_bytes >= 8 << 20


@needs_clips
def test_feet_and_guard_are_the_clis_options():
    motion = mc.read_bvh(str(SHARED / "cmu_mb_02_01.bvh"))
    noisy = motion.copy()
    noisy.rotations = mc.add_gaussian_noise(motion.rotations, sigma=0.02, seed=1)
    _, info = mc.auto(noisy)
    assert info["kept"].endswith("+lock"), info["kept"]
    free, free_info = mc.auto(noisy, feet="off")
    assert "lock" not in free_info["kept"], free_info["kept"]
    via_filter = mc.filter(noisy, "auto", {"feet": "off"})
    assert np.array_equal(bits(free.rotations), bits(via_filter.rotations))
    assert np.array_equal(bits(free.translations), bits(via_filter.translations))
    _, unguarded = mc.auto(noisy, guard="off")
    assert unguarded["kept"] is None
    with pytest.raises(ValueError, match="--feet"):
        mc.auto(noisy, feet="sideways")
