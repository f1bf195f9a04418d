"""Training: fit, checkpoints, exact resume (also after SIGKILL), mismatch errors, NaN stop, CLI, DDP."""

import pytest

pytest.importorskip("torch")  # the net extra: skipped by a core-only install

import errno
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import torch

import opnet
from opnet import train
from opnet.data import save_collection
from opnet.train import rundir

FAST = dict(hidden=64, batch_size=8, lr=1e-3, progress=False, checkpoint_every=0)  # a checkpoint every epoch


@pytest.fixture(scope="module")
def coll(tiny_collection):
    return tiny_collection()


def _weights(net):
    return {k: v.detach().clone() for k, v in net.state_dict().items()}


def _same_history(a, b):
    strip = [{k: v for k, v in h.items() if k != "seconds"} for h in a]
    return strip == [{k: v for k, v in h.items() if k != "seconds"} for h in b]


def test_fit_lowers_the_loss_and_selects_on_val(coll, tmp_path):
    net, hist = train.fit(coll, epochs=30, run_dir=tmp_path / "run", **FAST)
    assert isinstance(net, opnet.OperatorNet) and not net.training
    assert [h["epoch"] for h in hist] == list(range(1, 31))
    assert hist[-1]["train_loss"] < 0.2 * hist[0]["train_loss"]
    files = sorted(p.name for p in (tmp_path / "run").iterdir())
    assert files == sorted([*train.RUN_FILES, ".opnet-writer.lock"])  # the lock: one writer per run directory
    best = min(hist, key=lambda h: h["val_d_R"])
    # the returned network is the best epoch's: its val d_R is the best one in the history
    val = coll.indices("val")
    pred = opnet.evaluate.predict(net, coll.operators[val])
    assert np.isclose(opnet.d_R(coll.vertices[val], pred).mean(), best["val_d_R"], rtol=1e-4)
    assert json.loads((tmp_path / "run" / "history.json").read_text()) == hist
    config = json.loads((tmp_path / "run" / "config.json").read_text())
    assert config["data"]["fingerprint"] == train.collection_fingerprint(coll)
    assert config["model"]["channels"] == list(opnet.KINDS) and config["versions"]["torch"] == torch.__version__


def test_checkpoint_round_trip(coll, tmp_path):
    net, _ = train.fit(coll, epochs=3, run_dir=tmp_path, **FAST)
    loaded = train.load_model(tmp_path, coll, channels=opnet.KINDS)
    x = torch.from_numpy(coll.operators[:5])
    assert torch.equal(loaded(x), net(x))
    assert all(torch.equal(a, b) for a, b in zip(loaded.state_dict().values(), net.state_dict().values()))


def test_resume_gives_the_same_weights_and_history(coll, tmp_path):
    full, hist_full = train.fit(coll, epochs=6, run_dir=tmp_path / "a", **FAST)
    train.fit(coll, epochs=2, run_dir=tmp_path / "b", **FAST)  # "stopped" after epoch 2
    resumed, hist_resumed = train.fit(coll, epochs=6, run_dir=tmp_path / "b", **FAST)
    assert _same_history(hist_full, hist_resumed)
    assert all(torch.equal(a, b) for a, b in zip(_weights(full).values(), _weights(resumed).values()))
    a = torch.load(tmp_path / "a" / "latest.pt", weights_only=True)
    b = torch.load(tmp_path / "b" / "latest.pt", weights_only=True)
    assert all(torch.equal(a["model"][k], b["model"][k]) for k in a["model"])
    # a finished run is only loaded; fewer epochs than it has is refused
    again, hist_again = train.fit(coll, epochs=6, run_dir=tmp_path / "b", **FAST)
    assert hist_again == hist_resumed
    with pytest.raises(train.CheckpointError, match="already trained 6 epochs, more than epochs=4"):
        train.fit(coll, epochs=4, run_dir=tmp_path / "b", **FAST)


_KILLED_RUN = """
import sys, opnet
from opnet import train
from opnet.train import rundir
coll = opnet.data.read_collection(sys.argv[1])
train.fit(
    coll, epochs=int(sys.argv[3]), run_dir=sys.argv[2], hidden=64, batch_size=8, progress=False, checkpoint_every=0
)
"""


@pytest.mark.slow
def test_a_run_killed_with_sigkill_resumes_to_the_uninterrupted_result(coll, tmp_path):
    """A training SIGKILLed mid-run and resumed by a new process ends as one never interrupted. Every training runs
    in a fresh process, as a killed one is resumed: this test's own process, after the tests before it, may round
    differently in the last bit (a CI run saw 1e-9 apart at epoch 1 against a process of its own)."""
    manifest = save_collection(coll, tmp_path / "data" / "tiny")
    epochs = 150

    def train_in_a_process(run):
        return subprocess.Popen([sys.executable, "-c", _KILLED_RUN, str(manifest), str(run), str(epochs)])

    assert train_in_a_process(tmp_path / "ref").wait() == 0
    run = tmp_path / "killed"
    proc = train_in_a_process(run)
    deadline = time.time() + 120
    while time.time() < deadline and not (run / "latest.pt").exists():  # kill it in the middle of its epochs
        time.sleep(0.05)
    time.sleep(0.2)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    done = train.read_history(run)
    assert 0 < len(done) < epochs, "the run finished before it could be killed; the test needs a slower run"
    (run / ".latest.pt.tmp-99999999").write_bytes(b"partial")  # what a kill during a write leaves
    assert train_in_a_process(run).wait() == 0
    assert not list(run.glob(".*.tmp-*"))
    assert _same_history(train.read_history(tmp_path / "ref"), train.read_history(run))
    for name in ("best.pt", "latest.pt"):  # the best epoch's weights and the last one's
        ref, resumed = (torch.load(f / name, weights_only=True)["model"] for f in (tmp_path / "ref", run))
        assert ref.keys() == resumed.keys() and all(torch.equal(ref[k], resumed[k]) for k in ref), name


def test_a_second_writer_of_a_run_directory_stops_at_once_and_a_killed_one_leaves_no_lock(coll, tmp_path):
    """Two real processes: while one trains into a run directory, a second training there is refused with the folder
    and the holder's PID (a reader is not); once the first is SIGKILLed, the run resumes."""
    manifest = save_collection(coll, tmp_path / "data" / "tiny")
    run = tmp_path / "run"
    proc = subprocess.Popen([sys.executable, "-c", _KILLED_RUN, str(manifest), str(run), "100000"])
    try:
        deadline = time.time() + 120
        while time.time() < deadline and not (run / "best.pt").exists():
            time.sleep(0.05)
        with pytest.raises(
            opnet.FolderInUseError,
            match=rf"{run} is being written by training \(opnet.train.fit\) \(process {proc.pid}\)",
        ):
            train.fit(coll, epochs=3, run_dir=run, **FAST)
        assert train.load_model(run, coll) is not None  # a reader takes no lock
        assert proc.poll() is None  # the first writer goes on
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait()
    epochs = len(train.read_history(run)) + 2  # the lock went with its holder: the run resumes, two epochs more
    assert len(train.fit(coll, epochs=epochs, run_dir=run, **FAST)[1]) == epochs
    with opnet._files.writer_lock(run, "test"):  # and within one process, a second writer is refused too
        with pytest.raises(
            opnet.FolderInUseError,
            match=rf"by test \(process {os.getpid()}\); .* give this training \(opnet.train.fit\) another folder",
        ):
            train.fit(coll, epochs=1, run_dir=run, **FAST)


def test_a_full_disk_is_one_clear_error_and_the_run_resumes_from_its_intact_checkpoint(coll, tmp_path, monkeypatch):
    """torch's serializer on a full device fails with "unexpected pos"; opnet says the device is full, names the file,
    the folder and the space, keeps the previous checkpoint, and the run resumes to the uninterrupted result."""
    from opnet import _files

    run = tmp_path / "run"
    train.fit(coll, epochs=2, run_dir=run, **FAST)
    before = (run / "latest.pt").read_bytes()
    real_save = torch.save

    def full(obj, f, *args, **kwargs):  # what torch does when the device fills mid-write
        f.write(b"PK\x03\x04partial")
        raise RuntimeError("[enforce fail at inline_container.cc:672] . unexpected pos 3328 vs 3248")

    with monkeypatch.context() as m:
        m.setattr(torch, "save", full)
        usage = shutil.disk_usage(tmp_path)._replace(free=1200)
        m.setattr(_files.shutil, "disk_usage", lambda path: usage)
        with pytest.raises(
            opnet.DiskFullError, match=rf"no space left on the device for \w+\.pt in {run}: 1\.2 kB free"
        ):
            train.fit(coll, epochs=4, run_dir=run, **FAST)
    assert torch.save is real_save and (run / "latest.pt").read_bytes() == before  # the last checkpoint is intact
    assert not list(run.glob(".*.tmp-*"))  # and the partial file is gone
    _, resumed = train.fit(coll, epochs=4, run_dir=run, **FAST)
    _, straight = train.fit(coll, epochs=4, run_dir=tmp_path / "straight", **FAST)
    assert _same_history(resumed, straight)

    target = tmp_path / "results.json"  # an ENOSPC from any writer, e.g. json's: the same error
    target.write_text("{}")

    def enospc(f):
        f.write(b"{")
        raise OSError(errno.ENOSPC, "No space left on device")

    with pytest.raises(opnet.DiskFullError, match="for results.json in .*the previous results.json is intact"):
        _files.atomic_write(target, enospc)
    assert target.read_text() == "{}"


def test_a_corrupt_latest_checkpoint_costs_one_checkpoint_not_the_run(coll, tmp_path):
    """latest.pt unreadable (a disk fault): the run resumes from previous.pt, the checkpoint before it, says so, and
    ends as an uninterrupted run; with neither readable it is refused."""
    run = tmp_path / "run"
    train.fit(coll, epochs=3, run_dir=run, **FAST)
    assert rundir.read_checkpoint(run / "previous.pt")["epoch"] == 2  # kept when epoch 3's was written
    (run / "latest.pt").write_bytes(b"PK\x03\x04 a disk fault")
    with pytest.warns(UserWarning, match=r"latest.pt cannot be read .*resumes from previous.pt.*\(epoch 2\)"):
        _, resumed = train.fit(coll, epochs=5, run_dir=run, **FAST)
    _, straight = train.fit(coll, epochs=5, run_dir=tmp_path / "straight", **FAST)
    assert _same_history(resumed, straight)
    for name in ("latest.pt", "previous.pt"):
        (run / name).write_bytes(b"garbage")
    with pytest.raises(train.CheckpointError, match="latest.pt is not a readable opnet checkpoint"):
        train.fit(coll, epochs=6, run_dir=run, **FAST)


def test_mismatched_runs_and_checkpoints_are_refused(coll, tmp_path, tiny_collection):
    train.fit(coll, epochs=1, run_dir=tmp_path, **FAST)
    with pytest.raises(
        train.CheckpointError,
        match=r"other model settings: channels=\['area', 'conformal', 'extrinsic'\] there but \['extrinsic'\] here",
    ):
        train.fit(coll, channels="Ext", epochs=2, run_dir=tmp_path, **FAST)
    other = tiny_collection("other", seed=1)
    with pytest.raises(train.CheckpointError, match=r"tiny/tiny/430 seed 0 .*other/tiny/430 seed 1"):
        train.fit(other, epochs=2, run_dir=tmp_path, **FAST)
    with pytest.raises(train.CheckpointError, match="other train settings: lr=0.001 there but 0.5 here"):
        train.fit(coll, epochs=2, run_dir=tmp_path, **dict(FAST, lr=0.5))
    with pytest.raises(train.CheckpointError, match="hidden=64 there but 32 here.*--restart"):
        train.fit(coll, epochs=2, run_dir=tmp_path, **dict(FAST, hidden=32))
    with pytest.raises(train.CheckpointError, match="trained on tiny.*but this collection is other"):
        train.load_model(tmp_path, other)
    with pytest.raises(train.CheckpointError, match="channels area,conformal,extrinsic, not area"):
        train.load_model(tmp_path, channels=["area"])
    # resume=False replaces the run
    _, hist = train.fit(coll, channels="Ext", epochs=1, run_dir=tmp_path, resume=False, **FAST)
    assert train.load_model(tmp_path).channels == ("extrinsic",)


def test_corrupt_or_foreign_checkpoints_name_the_file(coll, tmp_path):
    train.fit(coll, epochs=1, run_dir=tmp_path, **FAST)
    best = tmp_path / "best.pt"
    best.write_bytes(best.read_bytes()[:1000])  # truncated
    with pytest.raises(train.CheckpointError, match=f"{best}.*corrupt"):
        train.load_model(tmp_path)
    torch.save({"weights": torch.zeros(2)}, best)
    with pytest.raises(train.CheckpointError, match="not an opnet checkpoint"):
        train.load_model(best)

    torch.save({"format": "opnet-checkpoint", "version": 1}, best)
    with pytest.raises(train.CheckpointError, match="incomplete opnet checkpoint"):
        train.load_model(best)

    class Evil:  # pickled code is refused by weights_only=True
        def __reduce__(self):
            return (os.system, ("echo hacked",))

    torch.save({"format": "opnet-checkpoint", "evil": Evil()}, best)
    with pytest.raises(train.CheckpointError, match=str(best)):
        train.load_model(best)
    (tmp_path / "latest.pt").write_bytes(b"garbage")
    with pytest.raises(train.CheckpointError, match="latest.pt"):
        train.fit(coll, epochs=2, run_dir=tmp_path, **FAST)


def test_nan_loss_stops_with_the_epoch_and_last_good_checkpoint(coll, tmp_path, monkeypatch):
    calls = {"n": 0}
    real = train.rigid_alignment_loss
    steps_per_epoch = -(-len(coll.indices("train")) // FAST["batch_size"])

    def flaky(pred, target, reduction="mean"):
        calls["n"] += pred.requires_grad  # training steps only, not validation
        out = real(pred, target, reduction)
        return out * np.nan if calls["n"] > 2 * steps_per_epoch else out

    monkeypatch.setattr(train, "rigid_alignment_loss", flaky)
    with pytest.raises(
        train.TrainingError,
        match=r"training loss became NaN or infinite in epoch 3; the last good checkpoint is .*latest.pt \(epoch 2\)",
    ):
        train.fit(coll, epochs=5, run_dir=tmp_path, **FAST)
    assert train.read_history(tmp_path)[-1]["epoch"] == 2
    calls["n"] = 0  # checkpoints every 30 s: none written yet when it diverges, and the message says so
    with pytest.raises(train.TrainingError, match=r"in epoch 3; the last good checkpoint is none"):
        train.fit(coll, epochs=5, run_dir=tmp_path / "timed", **dict(FAST, checkpoint_every=30))


def test_bad_arguments(coll, tmp_path, tiny_collection):
    with pytest.raises(ValueError, match="unknown channel 'volume'.*with_channels"):
        train.fit(coll, channels="area,volume", epochs=1)
    with pytest.raises(ValueError, match="epochs must be a positive integer"):
        train.fit(coll, epochs=0)
    with pytest.raises(ValueError, match="lr must be a positive number"):
        train.fit(coll, epochs=1, lr=float("nan"))
    with pytest.raises(ValueError, match="device"):
        train.fit(coll, epochs=1, device="tpu")
    (tmp_path / "file").write_text("x")
    with pytest.raises(ValueError, match="is a file"):
        train.fit(coll, epochs=1, run_dir=tmp_path / "file", **FAST)
    broken = tiny_collection("broken")
    broken.operators[3, 1, 2, 2] = np.nan
    with pytest.raises(ValueError, match="operators hold NaN or infinite values in 1 train/val shapes .first: shape 3"):
        train.fit(broken, epochs=1, **FAST)
    assert train.parse_channels("A+E") == ("area", "extrinsic")
    assert train.parse_channels("extrinsic, area") == ("extrinsic", "area")


def test_identity_subtraction_is_inside_the_network():
    torch.manual_seed(0)
    a = opnet.OperatorNet(50, k=10, hidden=16, subtract_identity=True)
    b = opnet.OperatorNet(50, k=10, hidden=16, subtract_identity=False)
    b.load_state_dict(a.state_dict())
    D = torch.randn(2, 3, 10, 10)
    assert torch.allclose(a(D), b(D - torch.eye(10)))
    assert not torch.allclose(a(D), b(D))


def test_variant_ours_standardises_and_decodes_from_the_base(coll, tmp_path):
    net, hist = train.fit(coll, epochs=4, run_dir=tmp_path / "ours", variant="ours", **FAST)
    assert net.standardize and net.residual
    tr = coll.indices("train")
    ops = torch.from_numpy(coll.operators[tr])
    assert torch.allclose(net.input_mean, ops.mean(0), atol=1e-6)
    assert torch.equal(net.base, torch.tensor(coll.base_basis.mesh.vertices, dtype=torch.float32))
    # the decoder's output is a displacement: with a zero last layer the network returns the base shape
    zero = train.load_model(tmp_path / "ours", coll)
    torch.nn.init.zeros_(zero.decoder[-1].weight), torch.nn.init.zeros_(zero.decoder[-1].bias)
    assert torch.allclose(zero(ops[:2]), zero.base.expand(2, -1, -1))
    # buffers travel with the checkpoint; the schedule is recorded and the learning rate decays to ~0
    loaded = train.load_model(tmp_path / "ours", coll)
    assert torch.equal(loaded(ops[:3]), net(ops[:3]))
    config = json.loads((tmp_path / "ours" / "config.json").read_text())
    assert config["train"]["schedule"] == "onecycle" and config["model"]["standardize"] is True
    latest = torch.load(tmp_path / "ours" / "latest.pt", weights_only=True)
    assert latest["optimizer"]["param_groups"][0]["lr"] < 0.05 * FAST["lr"]
    with pytest.raises(train.CheckpointError, match="epochs=4 there but 6 here"):
        train.fit(coll, epochs=6, run_dir=tmp_path / "ours", variant="ours", **FAST)
    with pytest.raises(ValueError, match="variant must be one of"):
        train.fit(coll, epochs=1, variant="mine", **FAST)
    # a network built by hand must have its statistics set before use; checkpoints without the flag load as set
    with pytest.raises(RuntimeError, match="set_statistics"):
        opnet.OperatorNet(net.n_vertices, k=net.k, standardize=True)(ops[:1])
    state = {k: v for k, v in net.state_dict().items() if k != "statistics_set"}
    fresh = opnet.OperatorNet(**net.config())
    fresh.load_state_dict(state)
    assert torch.equal(fresh(ops[:3]), net(ops[:3]))
    # each part alone (benchmarks/variants.py)
    alone, _ = train.fit(coll, epochs=1, standardize=True, **FAST)
    assert alone.standardize and not alone.residual


def test_checkpoints_every_few_seconds_keep_the_best_epoch(coll, tmp_path, monkeypatch):
    """A run checkpointed only at its end (the best weights kept in memory meanwhile) ends as one checkpointed
    after every epoch: the same history, the same best epoch, the same weights, and one write of each file.
    """
    every, hist_every = train.fit(coll, epochs=6, run_dir=tmp_path / "every", **FAST)
    writes = []
    real = rundir._save_torch
    monkeypatch.setattr(rundir, "_save_torch", lambda obj, path: (writes.append(path.name), real(obj, path)))
    once, hist_once = train.fit(coll, epochs=6, run_dir=tmp_path / "once", **dict(FAST, checkpoint_every=3600))
    assert writes == ["best.pt", "latest.pt"]
    assert _same_history(hist_every, hist_once)
    best = min(hist_every, key=lambda h: h["val_d_R"])["epoch"]
    assert 1 < best and rundir.read_checkpoint(tmp_path / "once" / "best.pt")["epoch"] == best
    assert all(torch.equal(a, b) for a, b in zip(_weights(every).values(), _weights(once).values()))


def test_onecycle_resume_is_exact(coll, tmp_path):
    full, hist_full = train.fit(coll, epochs=5, run_dir=tmp_path / "a", schedule="onecycle", **FAST)
    # interrupt a second run after 2 of its 5 epochs (at the progress bar's second update), then resume it
    ckpt_dir = tmp_path / "b"
    real = train.tqdm

    class Stop(Exception):
        pass

    calls = {"n": 0}

    class Bar(real):
        def update(self, n=1):
            calls["n"] += 1
            if calls["n"] == 2:
                raise Stop
            return super().update(n)

    train.tqdm = Bar
    try:
        with pytest.raises(Stop):
            train.fit(coll, epochs=5, run_dir=ckpt_dir, schedule="onecycle", **FAST)
    finally:
        train.tqdm = real
    assert [h["epoch"] for h in train.read_history(ckpt_dir)] == [1, 2]
    resumed, hist_resumed = train.fit(coll, epochs=5, run_dir=ckpt_dir, schedule="onecycle", **FAST)
    assert _same_history(hist_full, hist_resumed)
    assert all(torch.equal(a, b) for a, b in zip(_weights(full).values(), _weights(resumed).values()))


def test_operator_noise_changes_training_and_resumes_exactly(coll, tmp_path):
    _, plain = train.fit(coll, epochs=3, **FAST)
    full, noisy = train.fit(coll, epochs=3, operator_noise=0.5, run_dir=tmp_path / "a", **FAST)
    assert not _same_history(plain, noisy)  # the noise reaches the network
    train.fit(coll, epochs=2, operator_noise=0.5, run_dir=tmp_path / "b", **FAST)
    resumed, again = train.fit(coll, epochs=3, operator_noise=0.5, run_dir=tmp_path / "b", **FAST)
    assert _same_history(noisy, again)  # each epoch's noise is a function of the seed and the epoch
    assert all(torch.equal(a, b) for a, b in zip(_weights(full).values(), _weights(resumed).values()))
    record = json.loads((tmp_path / "a" / "config.json").read_text())["train"]
    assert record["operator_noise"] == 0.5
    train.fit(coll, epochs=1, run_dir=tmp_path / "c", **FAST)
    assert "operator_noise" not in json.loads((tmp_path / "c" / "config.json").read_text())["train"]  # older runs match
    with pytest.raises(train.CheckpointError):
        train.fit(coll, epochs=3, operator_noise=0.25, run_dir=tmp_path / "a", **FAST)
    with pytest.raises(ValueError, match="operator_noise are OperatorNet's options"):
        train.fit(coll, epochs=1, architecture="pointnet", operator_noise=0.5, progress=False)


def test_runs_saved_before_the_variant_options_still_resume(coll, tmp_path):
    train.fit(coll, epochs=2, run_dir=tmp_path, **FAST)
    config = json.loads((tmp_path / "config.json").read_text())
    ckpt = torch.load(tmp_path / "latest.pt", weights_only=True)
    for c in (config, ckpt["config"]):  # as written by the previous version
        for key in ("standardize", "residual"):
            c["model"].pop(key)
        c["train"].pop("schedule")
    (tmp_path / "config.json").write_text(json.dumps(config))
    torch.save(ckpt, tmp_path / "latest.pt")
    _, hist = train.fit(coll, epochs=3, run_dir=tmp_path, **FAST)
    assert [h["epoch"] for h in hist] == [1, 2, 3]


@pytest.mark.slow
def test_cli_help_explains_every_flag(capsys):
    """Every flag of every command has a help line, and ``--help`` prints it (parsed here: a process of its own per
    command took 4 s, most of it importing torch; the other CLI tests run ``python -m opnet`` itself)."""
    from opnet.__main__ import _parser

    parser = _parser()
    subcommands = parser._subparsers._group_actions[0].choices
    assert set(subcommands) == {"train", "evaluate", "reproduce"}
    for name, sub in subcommands.items():
        for action in sub._actions:
            assert action.help, (name, action.option_strings)
        with pytest.raises(SystemExit) as stop:
            parser.parse_args([name, "--help"])
        assert stop.value.code == 0 and "--device" in capsys.readouterr().out


@pytest.mark.slow
def test_cli_train_and_evaluate_on_a_saved_collection(coll, tmp_path, cli):
    manifest = save_collection(coll, tmp_path / "data" / "tiny")
    run = tmp_path / "run"
    out = cli(
        "train",
        "--collection",
        str(manifest),
        "--channels",
        "A+E",
        "--epochs",
        "2",
        "--hidden",
        "32",
        "--batch-size",
        "8",
        "--run-dir",
        str(run),
    )
    assert out.returncode == 0, out.stderr
    assert "best epoch" in out.stdout and train.load_model(run).channels == ("area", "extrinsic")
    out = cli("evaluate", "--run-dir", str(run), "--collection", str(manifest), "--json", str(tmp_path / "e.json"))
    assert out.returncode == 0, out.stderr
    rows = json.loads((tmp_path / "e.json").read_text())
    assert {r["method"] for r in rows} == {"OperatorNet (A+E)", "Nearest neighbour (A+E)", "Base shape"}
    bad = cli("train", "--collection", "cats", "--run-dir", str(run))
    assert bad.returncode == 2 and "--collection must be" in bad.stderr
    bad = cli("train", "--epochs", "0", "--run-dir", str(run))
    assert bad.returncode == 2 and "expected a positive integer" in bad.stderr
    bad = cli("evaluate", "--run-dir", str(tmp_path / "nothing"))
    assert bad.returncode != 0 and "no checkpoint at" in bad.stderr and "python -m opnet train" in bad.stderr


@pytest.mark.slow
@pytest.mark.parametrize("options", [[], ["--operator-noise", "0.5"]])
def test_ddp_with_two_processes_matches_one_process(coll, tmp_path, cli, free_port, options):
    """torchrun --nproc_per_node 2 (gloo) gives the single-process result with the same global batch (with operator
    noise too: the ranks split the global batch's noise).
    """
    manifest = save_collection(coll, tmp_path / "data" / "tiny")
    common = ["--collection", str(manifest), "--epochs", "3", "--hidden", "32", "--batch-size", "7", *options]
    single = cli("train", *common, "--run-dir", str(tmp_path / "one"))
    assert single.returncode == 0, single.stderr
    env = dict(os.environ, OMP_NUM_THREADS="1")
    ddp = subprocess.run(
        [
            sys.executable,
            "-m",
            "torch.distributed.run",
            "--nproc_per_node",
            "2",
            "--master_port",
            str(free_port()),  # one the OS says is free now, not one derived from the PID (it may be taken)
            "-m",
            "opnet",
            "train",
            *common,
            "--run-dir",
            str(tmp_path / "two"),
        ],
        capture_output=True,
        text=True,
        env=env,
    )
    assert ddp.returncode == 0, ddp.stderr[-3000:]
    one = torch.load(tmp_path / "one" / "latest.pt", weights_only=True)
    two = torch.load(tmp_path / "two" / "latest.pt", weights_only=True)
    assert two["config"]["world_size"] == 2 and one["config"]["world_size"] == 1
    for k in one["model"]:
        torch.testing.assert_close(two["model"][k], one["model"][k], rtol=1e-4, atol=1e-5)
    for h1, h2 in zip(one["history"], two["history"]):
        assert np.isclose(h1["train_loss"], h2["train_loss"], rtol=1e-4)
        assert np.isclose(h1["val_d_R"], h2["val_d_R"], rtol=1e-4)


def test_the_ranks_split_the_global_batch_and_its_noise():
    from opnet.train.loop import _shard

    batch = np.array([7, 3, 9, 1, 4])
    for world in (1, 2, 3, 6):  # every shape's noise row is used once, by the rank that computes that shape
        used = [_shard(batch, rank, world) for rank in range(world)]
        rows = np.concatenate([p[w > 0] for p, w in used])
        np.testing.assert_array_equal(np.sort(rows), np.arange(len(batch)))
        assert all(len(p) == len(w) >= 1 for p, w in used)  # every rank computes a shape, weighted 0 when not its own


def test_one_spec_trains_the_same_checkpoint_bit_for_bit_and_its_digest_names_it(coll, tmp_path):
    """A run's folder name carries a digest of what sets its weights, and training one spec twice on one machine
    gives the same best.pt, byte for byte: its SHA-256 names the training (what rows record in their provenance)."""
    from opnet.experiments import RunSpec

    spec = RunSpec(epochs=2, batch_size=8, hidden=16, group="det")
    a, b = spec.run_dir(tmp_path / "a", coll), spec.run_dir(tmp_path / "b", coll)
    assert a.name == b.name and a.name.startswith("det-A+E+C-d1-")
    for folder in (a, b):
        train.fit(coll, run_dir=folder, progress=False, **spec.fit_options())
    assert train.checkpoint_sha256(a) == train.checkpoint_sha256(b)
    assert train.run_digest(coll, **spec.fit_options()) == a.name.rsplit("-", 1)[1]
    # what sets the weights moves the digest; where it runs and how often it is checkpointed do not
    for other in (dict(epochs=3), dict(lr=5e-4), dict(schedule="onecycle"), dict(seed=1), dict(channels=["area"])):
        assert train.run_digest(coll, **{**spec.fit_options(), **other}) != train.run_digest(coll, **spec.fit_options())
    assert train.run_digest(coll, **spec.fit_options(), device="cpu", checkpoint_every=0) == a.name.rsplit("-", 1)[1]
    moved = coll.subset(np.arange(len(coll.vertices)))  # the same shapes: the same data
    assert train.run_digest(moved, **spec.fit_options()) == train.run_digest(coll, **spec.fit_options())


def test_the_optimiser_step_flushes_subnormals_in_one_thread_and_leaks_nothing():
    """Adam's second moments of weights whose gradients nearly vanish fall below float32's smallest normal number,
    where the CPU's slow path made each step of a default run 3-6 times as long: the optimiser's step never leaves
    one, on any number of threads, and after it neither this thread nor torch's workers flush (so the forward and
    backward passes compute as they would without it, whenever the workers were started)."""
    from opnet.train import loop

    tiny = torch.finfo(torch.float32).tiny
    cpu = torch.device("cpu")

    def subnormal(t):
        return int(((t != 0) & (t.abs() < tiny)).sum())

    def second_moments(step) -> torch.Tensor:
        weight = torch.nn.Parameter(torch.ones(100_000))
        optimizer = loop.adam([weight], 1e-3)
        for _ in range(3):
            weight.grad = torch.full((100_000,), 1e-20)  # its square, 1e-40, is subnormal
            step(optimizer)
        return optimizer.state[weight]["exp_avg_sq"]

    threads = torch.get_num_threads()
    torch.set_num_threads(2)
    try:
        tiny_values = torch.full((1_000_000,), 1e-20)
        assert subnormal(tiny_values * tiny_values) == 1_000_000  # torch's workers exist now, and do not flush
        assert subnormal(second_moments(lambda o: o.step())) == 100_000  # torch's own step keeps them (slowly)
        assert subnormal(second_moments(lambda o: loop.optimizer_step(o, cpu))) == 0
        assert torch.get_num_threads() == 2
        assert subnormal(tiny_values * tiny_values) == 1_000_000  # nothing flushes after it, workers included
    finally:
        torch.set_num_threads(threads)


def test_a_training_leaves_no_thread_flushing_subnormals(tiny_collection, tmp_path):
    """In a fresh process whose first parallel torch work is fit's (its workers start inside it), the process
    computes with subnormal numbers afterwards, on every thread."""
    code = (
        "import sys, torch, opnet; sys.path.insert(0, 'tests'); from conftest import _tiny_collection\n"
        "torch.set_num_threads(2)\n"
        "opnet.train.fit(_tiny_collection(), epochs=2, hidden=16, batch_size=8, progress=False)\n"
        "x = torch.full((1_000_000,), 1e-20) ** 2\n"
        "print(int(((x != 0) & (x.abs() < torch.finfo(torch.float32).tiny)).sum()))\n"
    )
    root = Path(__file__).resolve().parents[1]
    out = subprocess.run([sys.executable, "-c", code], cwd=root, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.split()[-1] == "1000000"
