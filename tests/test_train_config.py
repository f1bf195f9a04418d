"""TrainConfig: fit's hyper-parameters as a checked dataclass, and the `python -m opnet train` options generated
from its fields."""

import pytest

pytest.importorskip("torch")  # the net extra: skipped by a core-only install

import dataclasses
import inspect

import opnet
from opnet import train
from opnet.__main__ import _parser, main
from opnet.train import TrainConfig
from opnet.train.config import config_from_args

NOT_EXPOSED = {"standardize", "residual"}  # fit's options without a flag (benchmarks/variants.py sets them)
FLAGS = {  # the train options of the command line, as they were written by hand before
    "channels": "--channels",
    "depth": "--depth",
    "epochs": "--epochs",
    "batch_size": "--batch-size",
    "lr": "--lr",
    "seed": "--seed",
    "hidden": "--hidden",
    "subtract_identity": "--no-subtract-identity",
    "variant": "--variant",
    "schedule": "--schedule",
    "architecture": "--architecture",
    "n_points": "--points",
    "device": "--device",
    "checkpoint_every": "--checkpoint-every",
    "operator_noise": "--operator-noise",
}
OTHERS = {
    "--collection",
    "--preset",
    "--resolution",
    "--data-seed",
    "--bodies",
    "--poses",
    "--run-dir",
    "--restart",
    "--data-root",
}


def _train_parser():
    return _parser()._subparsers._group_actions[0].choices["train"]


def _parse(*words):
    return _parser().parse_args(["train", "--run-dir", "run", *words])


@pytest.fixture(scope="module")
def coll(tiny_collection):
    return tiny_collection()


def test_every_field_but_the_unexposed_has_its_flag():
    fields = {f.name for f in dataclasses.fields(TrainConfig)}
    assert fields - NOT_EXPOSED == set(FLAGS)
    actions = {a.dest: a for a in _train_parser()._actions if a.option_strings}
    for name, flag in FLAGS.items():
        assert actions[name].option_strings == [flag] and actions[name].help
    assert not NOT_EXPOSED & set(actions)
    assert {s for a in actions.values() for s in a.option_strings} == set(FLAGS.values()) | OTHERS | {"-h", "--help"}
    assert actions["depth"].choices == [1, 2, 3, 4]
    assert actions["variant"].choices == ["paper", "ours"] and actions["schedule"].choices == ["constant", "onecycle"]
    assert actions["architecture"].choices == ["operatornet", "pointnet", "pointnet_stn", "pointnet2"]


def test_fields_are_fits_arguments_with_its_defaults():
    params = inspect.signature(train.fit).parameters
    for f in dataclasses.fields(TrainConfig):
        assert params[f.name].default == f.default, f.name


def test_the_parsed_namespace_is_the_config_built_directly():
    assert config_from_args(_parse()) == TrainConfig()
    args = _parse(
        *("--channels", "A+E", "--depth", "3", "--epochs", "7", "--batch-size", "5", "--lr", "0.01", "--seed", "4"),
        *("--hidden", "16", "--no-subtract-identity", "--variant", "ours", "--schedule", "constant", "--device", "cpu"),
    )
    direct = TrainConfig(
        channels="A+E",
        depth=3,
        epochs=7,
        batch_size=5,
        lr=0.01,
        seed=4,
        hidden=16,
        subtract_identity=False,
        variant="ours",
        schedule="constant",
        device="cpu",
    )
    assert config_from_args(args) == direct
    assert config_from_args(_parse("--architecture", "pointnet", "--points", "64")) == TrainConfig(
        architecture="pointnet", n_points=64
    )
    assert config_from_args(_parse(), standardize=True) == TrainConfig(standardize=True)
    assert direct.as_kwargs()["channels"] == "A+E" and direct.lr_schedule == "constant"
    assert TrainConfig(variant="ours").lr_schedule == "onecycle" and TrainConfig(architecture="pointnet").points == 256
    with pytest.raises(dataclasses.FrozenInstanceError):
        direct.lr = 1.0


@pytest.mark.parametrize(
    "words, kwargs",
    [
        (("--lr", "nan"), dict(lr=float("nan"))),
        (("--lr", "-1"), dict(lr=-1.0)),
        (("--device", "tpu"), dict(device="tpu")),
        (("--architecture", "pointnet", "--channels", "A+E"), dict(architecture="pointnet", channels="A+E")),
        (("--architecture", "pointnet", "--depth", "2"), dict(architecture="pointnet", depth=2)),
        (("--points", "12"), dict(n_points=12)),
    ],
)
def test_a_bad_value_gives_fits_error(coll, words, kwargs, capsys):
    with pytest.raises(ValueError) as from_fit:
        train.fit(coll, epochs=1, progress=False, **kwargs)
    with pytest.raises(ValueError) as from_cli:
        config_from_args(_parse(*words))
    assert str(from_cli.value) == str(from_fit.value)
    with pytest.raises(ValueError) as direct:
        TrainConfig(**kwargs)
    assert str(direct.value) == str(from_fit.value)
    # the command refuses it before it builds or reads a collection
    assert main(["train", "--collection", "animals", "--run-dir", "run", *words]) == 1
    assert str(from_fit.value) in capsys.readouterr().err


def test_bad_values_refused_by_the_parser_and_by_the_config():
    with pytest.raises(SystemExit):
        _parse("--epochs", "0")
    with pytest.raises(SystemExit):
        _parse("--depth", "5")
    with pytest.raises(ValueError, match="epochs must be a positive integer, got 0"):
        TrainConfig(epochs=0)
    with pytest.raises(ValueError, match="depth must be 1, 2, 3 or 4"):
        TrainConfig(depth=5)
    with pytest.raises(ValueError, match="variant must be one of"):
        TrainConfig(variant="mine")
    with pytest.raises(ValueError, match="schedule must be one of"):
        TrainConfig(schedule="linear")
    with pytest.raises(ValueError, match="architecture must be one of"):
        TrainConfig(architecture="mlp")


def test_bodies_and_poses_reach_the_collection(monkeypatch):
    from opnet import __main__ as cli_module
    from opnet.data.generators import BODIES, POSES

    assert _train_parser()._option_string_actions["--bodies"].choices == list(BODIES)
    assert _train_parser()._option_string_actions["--poses"].choices == list(POSES)
    seen = {}
    monkeypatch.setattr("opnet.data.load_collection", lambda *a, **k: seen.update(k) or "collection")
    words = ("--collection", "humans", "--bodies", "shape", "--poses", "quarter")
    assert cli_module._collection(_parse(*words)) == "collection"
    assert seen["bodies"] == "shape" and seen["poses"] == "quarter"
    for flag, value in (("--bodies", "shape"), ("--poses", "mixed")):
        with pytest.raises(SystemExit):  # a saved collection's bodies and poses are what they are
            cli_module._collection(_parse("--collection", "saved.json", flag, value))


def test_a_run_records_its_collections_draws(humans, root):
    """The data part of a run's config names the generated collection's draws (bodies, poses), so that `opnet
    evaluate` loads the collection it was trained on; the collection as designed records none (older runs match)."""
    from opnet.train.rundir import _data_config, comparable

    more = opnet.data.load_collection("humans", "quick", root, bodies="shape", poses="quarter", progress=False)
    assert {k: _data_config(more, ["area"])[k] for k in ("bodies", "poses")} == {"bodies": "shape", "poses": "quarter"}
    assert not {"bodies", "poses"} & set(_data_config(humans, ["area"]))
    # information, not compared: a run saved before the draws were recorded resumes and loads (the fingerprint, which
    # covers the operators, tells other draws apart)
    recorded = _data_config(more, ["area"])
    older = {k: v for k, v in recorded.items() if k not in ("bodies", "poses")}
    assert comparable(older) == comparable(recorded) and comparable(recorded) != comparable(
        _data_config(humans, ["area"])
    )


def test_a_run_is_named_by_its_options_values():
    """The run folder of a spec: its options digested by value (1 and 1.0 are one training), not by their spelling."""
    import numpy as np

    from opnet.experiments import RunSpec

    one, *same = (RunSpec(channels=("extrinsic",), options={"operator_noise": v}) for v in (1, 1.0, np.float64(1)))
    assert one.run_name == same[0].run_name == same[1].run_name != RunSpec(channels=("extrinsic",)).run_name
    assert one.run_name != RunSpec(channels=("extrinsic",), options={"operator_noise": 0.25}).run_name
    assert RunSpec(channels=("extrinsic",), options={"standardize": True}).run_name != one.run_name


def test_evaluate_loads_the_collection_a_run_was_trained_on(monkeypatch, tmp_path):
    """`opnet evaluate` of a run of a generated collection with draws loads that collection, draws and all."""
    data = dict(name="humans", preset="quick", resolution="1k", seed=0, bodies="shape", poses="quarter")
    monkeypatch.setattr("opnet.train.checkpoint_path", lambda run_dir: tmp_path / "best.pt")
    monkeypatch.setattr("opnet.train.read_checkpoint", lambda path, **kw: {"config": {"data": data}})
    seen = {}

    def load(*args, **kwargs):
        seen.update(kwargs)
        raise RuntimeError("loaded")  # far enough: what it was asked for is recorded

    monkeypatch.setattr("opnet.data.load_collection", load)
    with pytest.raises(RuntimeError, match="loaded"):
        main(["evaluate", "--run-dir", str(tmp_path)])
    assert seen["bodies"] == "shape" and seen["poses"] == "quarter" and seen["seed"] == 0
