"""The trainer skeleton (weavecap.training.trainer) on a problem with a known answer: a line
fitted to exact data, trained whole and trained with an interruption, shards made once."""

import json

import numpy as np
import pytest

torch = pytest.importorskip("torch")

from weavecap.training import trainer as skeleton  # noqa: E402

SLOPE, INTERCEPT = 2.5, -0.75


def _line_data(n: int = 64):
    x = torch.linspace(-1.0, 1.0, n).reshape(-1, 1)
    return x, SLOPE * x + INTERCEPT


def _trainer(folder, settings, *, lr=0.05, messages=None):
    torch.manual_seed(0)
    model = torch.nn.Linear(1, 1)
    opt = torch.optim.Adam(model.parameters(), lr=lr)
    sched = torch.optim.lr_scheduler.StepLR(opt, step_size=200, gamma=0.5)
    return skeleton.Trainer(folder, settings, model, opt, sched, progress=messages.append if messages is not None else print)


def _epochs(trainer, count):
    x, y = _line_data()
    trainer.epochs(count, len(x), 8, 0, lambda idx: torch.mean((trainer.model(x[idx]) - y[idx]) ** 2))


def _state(model):
    return {k: v.detach().clone() for k, v in model.state_dict().items()}


def test_epochs_fit_the_line_and_a_resumed_run_matches_an_uninterrupted_one(tmp_path):
    whole = _trainer(tmp_path / "whole", {"lr": 0.05})
    _epochs(whole, 60)
    weight, bias = float(whole.model.weight.detach()), float(whole.model.bias.detach())
    assert weight == pytest.approx(SLOPE, abs=1e-3) and bias == pytest.approx(INTERCEPT, abs=1e-3)
    assert whole.done == 60 and whole.seconds > 0

    first = _trainer(tmp_path / "cut", {"lr": 0.05})
    _epochs(first, 23)  # stopped after 23 epochs
    messages = []
    again = _trainer(tmp_path / "cut", {"lr": 0.05}, messages=messages)
    assert again.done == 23 and "resuming after 23" in messages[0]
    _epochs(again, 60)
    for key, value in _state(whole.model).items():
        torch.testing.assert_close(_state(again.model)[key], value, rtol=0, atol=0)


def test_a_checkpoint_of_other_settings_is_set_aside(tmp_path):
    _epochs(_trainer(tmp_path, {"lr": 0.05}), 3)
    messages = []
    other = _trainer(tmp_path, {"lr": 0.01}, lr=0.01, messages=messages)
    assert other.done == 0 and other.seconds == 0.0 and "other training settings" in messages[0]


def test_steps_checkpoint_every_n_and_resume_exactly(tmp_path):
    x, y = _line_data()

    def run(trainer, count):
        def loss(k):  # step k's batch from its own generator: a resumed run draws the same batches
            idx = torch.from_numpy(np.random.default_rng([7, k]).choice(len(x), 8, replace=False))
            return torch.mean((trainer.model(x[idx]) - y[idx]) ** 2)
        trainer.steps(count, loss, every=10)

    whole = _trainer(tmp_path / "whole", {"s": 1})
    run(whole, 40)
    cut = _trainer(tmp_path / "cut", {"s": 1})
    run(cut, 25)  # checkpoints at 10, 20 and 25 (the end)
    assert _trainer(tmp_path / "cut", {"s": 1}).done == 25
    resumed = _trainer(tmp_path / "cut", {"s": 1})
    run(resumed, 40)
    for key, value in _state(whole.model).items():
        torch.testing.assert_close(_state(resumed.model)[key], value, rtol=0, atol=0)


def test_shards_are_made_once_and_their_seconds_summed(tmp_path):
    paths = [skeleton.shard_path(tmp_path / "data", k) for k in range(3)]
    made, messages = [], []

    def make(k):
        made.append(k)
        return {"x": np.full((k + 1, 2), k, np.float32)}

    first = skeleton.make_shards(paths, make, progress=messages.append, describe=lambda a: f"{len(a['x'])} rows")
    assert made == [0, 1, 2] and len(messages) == 3 and "shard 2/3 (2 rows" in messages[1]
    paths[1].unlink()  # as if the run had stopped before it
    again = skeleton.make_shards(paths, make, progress=messages.append)
    assert made == [0, 1, 2, 1] and len(messages) == 4
    assert again == pytest.approx(sum(skeleton.shard_seconds(p) for p in paths)) and first > 0
    data = skeleton.concatenate_shards(paths, ["x"])
    np.testing.assert_array_equal(data["x"][:, 0], [0, 1, 1, 2, 2, 2])


@pytest.mark.parametrize("suffix", [".pt", ".npz"])
def test_weights_are_written_with_their_record(tmp_path, suffix):
    model = torch.nn.Linear(3, 2)
    path = tmp_path / f"net{suffix}"
    record_path = skeleton.write_weights(path, model, {"format": "test/1", "seconds": {"train": 1.5}})
    assert record_path == tmp_path / "net.json"
    assert json.loads(record_path.read_text()) == {"format": "test/1", "seconds": {"train": 1.5}}
    if suffix == ".pt":
        state = torch.load(path, weights_only=True)
        torch.testing.assert_close(state["weight"], model.weight.detach())
    else:
        with np.load(path, allow_pickle=False) as z:
            np.testing.assert_allclose(z["weight"], model.weight.detach().numpy(), rtol=1e-7)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([path.name, "net.json"])  # no temporaries left
    with pytest.raises(ValueError, match=".pt or .npz"):
        skeleton.write_weights(tmp_path / "net.bin", model, {})
