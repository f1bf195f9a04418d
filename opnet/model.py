"""OperatorNet (section 5 of the paper): shape differences in, vertex coordinates out, and its loss (eq. 9);
the PointNet autoencoder the paper compares with (section 7, Appendix C).

OperatorNet reads ``C`` shape-difference matrices ``(C, k, k)`` as image channels: a shallow
convolutional encoder (3 × 3 convolutions, stride 2, 8 filters doubling per layer, ReLU; one layer by
default, the paper's best in its ablation, Appendix B) and a dense decoder (1024, 1024, n · 3).
:class:`PointNetAutoencoder` reads the coordinates themselves with a PointNet encoder and decodes them with
the same dense decoder; :class:`PointNetTransformerAutoencoder` adds PointNet's input transform and
:class:`PointNet2Autoencoder` reads them with a PointNet++ encoder. :data:`ARCHITECTURES` names the four for
:func:`build_model` and the trainer.
"""

from __future__ import annotations

import numpy as np
import torch
from torch import nn

from ._checks import describe, real_array
from .shape_difference import KINDS

__all__ = [
    "OperatorNet",
    "PointNetAutoencoder",
    "PointNetTransformerAutoencoder",
    "PointNet2Autoencoder",
    "InputTransform",
    "farthest_points",
    "build_model",
    "rigid_alignment_loss",
    "kabsch_torch",
    "VARIANTS",
    "ARCHITECTURES",
]

#: Named network settings: the paper's architecture (fed ``D − I``), and this project's variant.
VARIANTS = {"paper": dict(), "ours": dict(standardize=True, residual=True)}


def as_input(name: str, x, module: nn.Module, shape: tuple, shape_text: str) -> torch.Tensor:
    """``x`` as a tensor of ``module``'s dtype on its device, of shape ``shape`` (``None``: any size).

    Tensors and arrays of the network's precision or narrower (float16 for a float32 network, integers) are
    converted; nested lists, which carry no precision, are read in the network's. Wider floats (float64 for a
    float32 network) are refused with the fix, as are complex, non-numeric and wrongly shaped values
    (``TypeError``/``ValueError`` naming ``name`` and ``shape_text``). Values are not checked for NaN here, in
    the training loop's path: :func:`opnet.evaluate.predict` and :func:`opnet.evaluate.decode` check them.
    """
    param = next(module.parameters())
    fix = (
        f"pass {shape_text} real values in {str(param.dtype).replace('torch.', '')} (x.float() or "
        "np.float32 arrays), or use opnet.evaluate.predict(net, x), which converts and batches"
    )
    if not isinstance(x, torch.Tensor):
        try:  # nested lists hold numbers of no declared precision: read in the network's
            arr = np.asarray(x) if isinstance(x, np.ndarray) else np.asarray(x, dtype=str(param.dtype)[6:])
        except (ValueError, TypeError):
            arr = np.asarray(None)
        if arr.dtype.kind not in "fiu":
            raise TypeError(f"{name} must be a tensor {shape_text} of real numbers, got {describe(x)}; {fix}.")
        x = torch.tensor(arr)
    if x.is_complex() or x.dtype == torch.bool:
        raise TypeError(f"{name} must hold real numbers, got {x.dtype}; {fix}.")
    if x.is_floating_point() and x.dtype != param.dtype and x.element_size() > param.element_size():
        raise TypeError(
            f"{name} is {str(x.dtype).replace('torch.', '')} of shape {tuple(x.shape)} but this network "
            f"computes in {str(param.dtype).replace('torch.', '')}, which would round it; {fix} (or "
            "net.double())."
        )
    if x.ndim != len(shape) or any(s is not None and a != s for a, s in zip(x.shape, shape)):
        raise ValueError(f"{name} must have shape {shape_text}, got {tuple(x.shape)}.")
    return x.to(dtype=param.dtype, device=param.device)


class OperatorNet(nn.Module):
    """Shape differences ``(B, C, k, k)`` → vertex coordinates ``(B, n_vertices, 3)``.

    Parameters
    ----------
    n_vertices : number of output vertices ``n``.
    k : size of the operators (the base basis size, 60 in the paper).
    channels : the names of the input operators, in order (any channels: built-in or your own inner products;
        instances are taken by name). The network reads ``len(channels)`` input maps; the names are metadata that
        :func:`opnet.decode` and the evaluation use to pick the right operators.
    depth : convolution layers in the encoder, 1 to 4 (filters 8, 16, 32, 64).
    hidden : width of the two hidden dense layers (1024 in the paper).
    subtract_identity : feed the encoder ``D − I`` instead of ``D`` (default ``True``; the paper feeds ``D``).
        Shape differences of shapes close to the base are close to the identity, so ``D − I`` is the part
        that varies and a zero input means "the base shape"; it is subtracted inside :meth:`forward`, so the
        network is always called on the operators themselves.
    standardize : feed ``(D − μ) / σ`` with ``μ``, ``σ`` the per-entry mean and standard deviation of the training
        operators (buffers ``input_mean``, ``input_std`` ``(C, k, k)``, set by :meth:`set_statistics`; replaces
        ``subtract_identity``). The entries of ``D − I`` are ~1e-2, so the first layer otherwise sees tiny inputs.
    residual : decode a displacement from the base shape (buffer ``base`` ``(n, 3)``, set by
        :meth:`set_statistics`): the output is ``base + decoder(·)``, so an untrained network starts at the base.

    Notes
    -----
    ``standardize=True, residual=True`` is this project's variant (:data:`VARIANTS` ``["ours"]``); ``docs/results.md``
    reports how each part changes the validation error. Both sets of buffers are saved with the weights.
    """

    def __init__(
        self,
        n_vertices: int,
        k: int = 60,
        channels=KINDS,
        depth: int = 1,
        hidden: int = 1024,
        subtract_identity: bool = True,
        standardize: bool = False,
        residual: bool = False,
    ):
        super().__init__()
        channels = tuple(getattr(c, "name", c) for c in ((channels,) if isinstance(channels, str) else channels))
        if not channels or not all(isinstance(c, str) for c in channels) or len(set(channels)) != len(channels):
            raise ValueError(f"channels must be channel names (e.g. {KINDS}) without repeats, got {channels!r}.")
        if depth not in (1, 2, 3, 4):
            raise ValueError(f"depth must be 1, 2, 3 or 4 convolution layers (the paper's ablation), got {depth!r}.")
        if n_vertices < 4 or k < 1:
            raise ValueError(f"need n_vertices >= 4 and k >= 1, got {n_vertices} and {k}.")
        self.n_vertices, self.k, self.channels, self.depth = n_vertices, k, channels, depth
        self.hidden, self.subtract_identity = hidden, bool(subtract_identity)
        self.standardize, self.residual = bool(standardize), bool(residual)
        if self.standardize:
            self.register_buffer("input_mean", torch.zeros(len(channels), k, k))
            self.register_buffer("input_std", torch.ones(len(channels), k, k))
        if self.residual:
            self.register_buffer("base", torch.zeros(n_vertices, 3))
        if self.standardize or self.residual:  # saved with the weights, so a loaded network counts as set
            self.register_buffer("statistics_set", torch.tensor(False))
            self._register_load_state_dict_pre_hook(_statistics_were_set)
        layers, width, size = [], len(channels), k
        for i in range(depth):
            layers += [nn.Conv2d(width, 8 * 2**i, kernel_size=3, stride=2, padding=1), nn.ReLU()]
            width, size = 8 * 2**i, (size + 1) // 2
        self.encoder = nn.Sequential(*layers, nn.Flatten())
        self.decoder = dense_decoder(width * size * size, hidden, n_vertices)

    def forward(self, operators: torch.Tensor) -> torch.Tensor:
        """Vertices ``(B, n_vertices, 3)`` from operators ``(B, C, k, k)`` (float32 or narrower; the ``channels``)."""
        operators = as_input(
            "operators",
            operators,
            self,
            (None, len(self.channels), self.k, self.k),
            f"(B, {len(self.channels)}, {self.k}, {self.k}) (channels {self.channels})",
        )
        if (self.standardize or self.residual) and not self.statistics_set:
            raise RuntimeError(
                "this OperatorNet standardizes its inputs or decodes from the base, but its statistics "
                "are not set: call net.set_statistics(train_operators, base_vertices) first (fit does)."
            )
        if self.standardize:
            operators = (operators - self.input_mean) / self.input_std
        elif self.subtract_identity:
            operators = operators - torch.eye(self.k, dtype=operators.dtype, device=operators.device)
        out = self.decoder(self.encoder(operators)).view(-1, self.n_vertices, 3)
        return out + self.base if self.residual else out

    def set_statistics(self, operators: torch.Tensor, base_vertices=None) -> "OperatorNet":
        """Set the buffers of ``standardize`` (from training operators ``(N, C, k, k)``) and ``residual`` (the base
        shape's vertices ``(n, 3)``); :func:`opnet.train.fit` calls it before training. Returns ``self``.
        """
        with torch.no_grad():
            if self.standardize:
                ops = torch.as_tensor(operators, dtype=torch.float64)
                self.input_mean.copy_(ops.mean(0))
                # entries that never vary (e.g. the constant function's row of D^C) get σ = 1
                std = ops.std(0)
                self.input_std.copy_(torch.where(std > 1e-8, std, torch.ones_like(std)))
            if self.residual:
                if base_vertices is None or tuple(np.shape(base_vertices)) != (self.n_vertices, 3):
                    raise ValueError(
                        f"residual=True needs the base shape's vertices ({self.n_vertices}, 3), got "
                        f"{None if base_vertices is None else np.shape(base_vertices)}."
                    )
                self.base.copy_(torch.tensor(np.asarray(base_vertices), dtype=self.base.dtype))
            if self.standardize or self.residual:
                self.statistics_set.fill_(True)
        return self

    def config(self) -> dict:
        """The constructor's arguments, enough to rebuild the network (stored in checkpoints)."""
        return dict(
            n_vertices=self.n_vertices,
            k=self.k,
            channels=list(self.channels),
            depth=self.depth,
            hidden=self.hidden,
            subtract_identity=self.subtract_identity,
            standardize=self.standardize,
            residual=self.residual,
        )


def dense_decoder(in_features: int, hidden: int, n_vertices: int) -> nn.Sequential:
    """OperatorNet's decoder: ``in_features`` → ``hidden`` → ``hidden`` → ``3 n`` (ReLU between), as ``(n, 3)``."""
    return nn.Sequential(
        nn.Linear(in_features, hidden),
        nn.ReLU(),
        nn.Linear(hidden, hidden),
        nn.ReLU(),
        nn.Linear(hidden, 3 * n_vertices),
    )


class PointNetAutoencoder(nn.Module):
    """Coordinates ``(B, n, 3)`` → a latent code ``(B, latent)`` → coordinates ``(B, n, 3)``: the paper's baseline.

    The encoder is PointNet without its spatial transformer (the paper's better variant, section 7;
    :class:`PointNetTransformerAutoencoder` has it): a shared per-point
    MLP ``3 → 64 → 128 → latent`` (ReLU) and a max over the points, so the code does not depend on the order of
    the points. It reads ``n_points`` of the ``n`` vertices, the same ones for every shape (buffer
    ``point_index``, spread over the base shape by :meth:`choose_points`; all vertices when ``n_points`` is
    ``None``): the per-point MLP's cost grows with the points, and a few hundred cover a body.
    The decoder is OperatorNet's (``dense_decoder``, ``latent → hidden → hidden → 3 n``), so the two
    networks differ only in what they read: coordinates here, shape differences there. Its algebra is linear in
    the code: interpolation ``(1 − t) z_0 + t z_1`` and analogy ``z_X = z_C + z_B − z_A`` (:mod:`opnet.apps`).

    Parameters
    ----------
    n_vertices : number of vertices ``n`` of the shapes read and written.
    n_points : vertices the encoder reads (``None``: all).
    latent : size of the code (1024 in PointNet).
    hidden : width of the decoder's two hidden layers (1024, as OperatorNet's).
    """

    #: The name :data:`ARCHITECTURES` gives it, stored in its ``config()``.
    architecture = "pointnet"

    def __init__(self, n_vertices: int, n_points: int | None = None, latent: int = 1024, hidden: int = 1024):
        super().__init__()
        n_points = n_vertices if n_points is None else n_points
        if n_vertices < 4 or not 1 <= n_points <= n_vertices or latent < 1 or hidden < 1:
            raise ValueError(
                f"need n_vertices >= 4, 1 <= n_points <= n_vertices, latent >= 1 and hidden >= 1, got "
                f"{n_vertices}, {n_points}, {latent}, {hidden}."
            )
        self.n_vertices, self.n_points, self.latent, self.hidden = n_vertices, n_points, latent, hidden
        self.register_buffer("point_index", torch.linspace(0, n_vertices - 1, n_points).round().long())
        self.point_mlp = nn.Sequential(
            nn.Linear(3, 64), nn.ReLU(), nn.Linear(64, 128), nn.ReLU(), nn.Linear(128, latent), nn.ReLU()
        )
        self.decoder = dense_decoder(latent, hidden, n_vertices)
        self.transform = None  # PointNetTransformerAutoencoder's input transform

    def choose_points(self, base_vertices) -> "PointNetAutoencoder":
        """Read the ``n_points`` vertices spread furthest apart on the base shape ``(n, 3)``
        (:func:`opnet.mesh.furthest_vertices`); :func:`opnet.train.fit` calls it. Returns ``self``.
        """
        from .mesh import furthest_vertices

        if tuple(np.shape(base_vertices)) != (self.n_vertices, 3):
            raise ValueError(f"base_vertices must be ({self.n_vertices}, 3), got {np.shape(base_vertices)}.")
        index = np.sort(furthest_vertices(base_vertices, self.n_points))
        if len(index) < self.n_points:
            raise ValueError(
                f"the base shape has only {len(index)} distinct vertices, fewer than n_points={self.n_points}."
            )
        self.point_index.copy_(torch.from_numpy(index))
        return self

    def encode(self, vertices: torch.Tensor) -> torch.Tensor:
        """Vertices ``(B, n, 3)`` → codes ``(B, latent)`` (from the ``n_points`` read)."""
        vertices = as_input("vertices", vertices, self, (None, self.n_vertices, 3), f"(B, {self.n_vertices}, 3)")
        points = vertices[:, self.point_index]
        if self.transform is not None:
            points = points @ self.transform(points)
        return self.point_mlp(points).amax(dim=1)

    def decode(self, codes: torch.Tensor) -> torch.Tensor:
        """Codes ``(B, latent)`` → vertices ``(B, n, 3)``."""
        codes = as_input("codes", codes, self, (None, self.latent), f"(B, {self.latent})")
        return self.decoder(codes).view(-1, self.n_vertices, 3)

    def forward(self, vertices: torch.Tensor) -> torch.Tensor:
        """Reconstructed vertices ``(B, n_vertices, 3)`` from vertices ``(B, n_vertices, 3)``: decode(encode(·))."""
        return self.decode(self.encode(vertices))

    def config(self) -> dict:
        """The constructor's arguments and its :attr:`architecture` (stored in checkpoints; :func:`build_model`)."""
        return dict(
            architecture=self.architecture,
            n_vertices=self.n_vertices,
            n_points=self.n_points,
            latent=self.latent,
            hidden=self.hidden,
        )


class InputTransform(nn.Module):
    """PointNet's input transform (its spatial transformer, the T-Net of Qi et al. 2017): a ``3 × 3`` matrix
    ``(B, 3, 3)`` predicted from points ``(B, p, 3)`` by a per-point MLP ``3 → 64 → 128 → 1024`` (ReLU), a max over
    the points and a dense head ``1024 → 512 → 256 → 9``; its last layer starts at zero, so the transform starts
    as the identity. The points are multiplied by it, ``points @ T``, before the encoder reads them.
    """

    def __init__(self, width: int = 1024):
        super().__init__()
        self.point_mlp = nn.Sequential(
            nn.Linear(3, 64), nn.ReLU(), nn.Linear(64, 128), nn.ReLU(), nn.Linear(128, width), nn.ReLU()
        )
        self.head = nn.Sequential(nn.Linear(width, 512), nn.ReLU(), nn.Linear(512, 256), nn.ReLU(), nn.Linear(256, 9))
        nn.init.zeros_(self.head[-1].weight)
        nn.init.zeros_(self.head[-1].bias)

    def forward(self, points: torch.Tensor) -> torch.Tensor:
        """The transforms ``(B, 3, 3)`` of point sets ``(B, p, 3)``."""
        eye = torch.eye(3, dtype=points.dtype, device=points.device)
        return eye + self.head(self.point_mlp(points).amax(dim=1)).view(-1, 3, 3)


class PointNetTransformerAutoencoder(PointNetAutoencoder):
    """:class:`PointNetAutoencoder` with PointNet's input transform (:class:`InputTransform`): the paper's other
    PointNet autoencoder (section 7: "one autoencoder with spatial transformers and one without"; it kept the one
    without, which did better). The feature transform (``64 × 64``) of the classification network and its
    orthogonality penalty are left out: the loss stays eq. 9 for every network.
    """

    architecture = "pointnet_stn"

    def __init__(self, n_vertices: int, n_points: int | None = None, latent: int = 1024, hidden: int = 1024):
        super().__init__(n_vertices, n_points, latent, hidden)
        self.transform = InputTransform()


class PointNet2Autoencoder(PointNetAutoencoder):
    """A PointNet++ encoder (Qi et al. 2017, "PointNet++", single-scale grouping) with OperatorNet's dense decoder:
    the autoencoder of the paper's Appendix (Fig. 17).

    The encoder reads the ``n_points`` vertices of :meth:`~PointNetAutoencoder.choose_points` and abstracts them
    twice: farthest-point sampling picks ``128`` then ``32`` centres on each shape, each centre groups its ``32``
    nearest points within a radius (``0.1`` then ``0.2`` of the base shape's bounding-box diagonal; points beyond it
    are replaced by the nearest one, as the reference ball query pads its groups), and a shared MLP of the group's
    offsets from its centre (and, at the second level, their features) ``→ 64 → 64 → 128`` then ``→ 128 → 128 →
    256``, maxed over the group, gives the centre's feature. A last MLP ``→ 256 → 512 → latent`` over the 32 centres
    (their positions and features), maxed, is the code. The decoder is the same dense decoder.
    """

    architecture = "pointnet2"
    #: (centres, group size, radius as a fraction of the base's bounding-box diagonal) of the two abstractions.
    LEVELS = ((128, 32, 0.1), (32, 32, 0.2))

    def __init__(self, n_vertices: int, n_points: int | None = None, latent: int = 1024, hidden: int = 1024):
        super().__init__(n_vertices, n_points, latent, hidden)
        del self.point_mlp

        def mlp(*widths):
            layers = []
            for a, b in zip(widths[:-1], widths[1:]):
                layers += [nn.Linear(a, b), nn.ReLU()]
            return nn.Sequential(*layers)

        self.levels = nn.ModuleList([mlp(3, 64, 64, 128), mlp(128 + 3, 128, 128, 256)])
        self.global_mlp = mlp(256 + 3, 256, 512, latent)
        self.register_buffer("radius", torch.tensor([r for *_, r in self.LEVELS], dtype=torch.float32))

    def choose_points(self, base_vertices) -> "PointNet2Autoencoder":
        """:meth:`PointNetAutoencoder.choose_points`, and the grouping radii from the base's bounding-box diagonal."""
        super().choose_points(base_vertices)
        v = np.asarray(base_vertices, dtype=np.float64)
        diagonal = float(np.linalg.norm(v.max(0) - v.min(0)))
        self.radius.copy_(torch.tensor([diagonal * r for *_, r in self.LEVELS], dtype=self.radius.dtype))
        return self

    def encode(self, vertices: torch.Tensor) -> torch.Tensor:
        """Vertices ``(B, n, 3)`` → codes ``(B, latent)``. Each level's MLP starts with a linear layer of the group
        member's ``[offset, feature]``, ``W [x_j − c; f_j] = W_x (x_j − c) + W_f f_j``: the ``W_f f_j`` term is
        computed once per point and then grouped, not once per member (a point belongs to several groups), and the
        max over a group is ``max``, whose gradient goes to one of tied members where ``amax`` splits it among them:
        the ties are a group's padding (the nearest point repeated: the same inputs, so the same weight gradients)
        or zeros after the ReLU (no gradient either way). The same function and weights as the whole MLP on the
        concatenated groups with ``amax``, in a shorter training step (``benchmarks/point_steps.py`` times both).
        """
        vertices = as_input("vertices", vertices, self, (None, self.n_vertices, 3), f"(B, {self.n_vertices}, 3)")
        xyz, features = vertices[:, self.point_index], None
        b = torch.arange(len(xyz), device=xyz.device)[:, None]
        for (centres, group, _), radius, level in zip(self.LEVELS, self.radius, self.levels):
            with torch.no_grad():  # which points group: no gradient flows through the choice
                chosen = farthest_points(xyz, min(centres, xyz.shape[1]))  # (B, m)
                near, idx = torch.cdist(xyz[b, chosen], xyz).topk(min(group, xyz.shape[1]), dim=-1, largest=False)
                idx = torch.where(near <= radius, idx, idx[..., :1])  # beyond the radius: the nearest point again
            centre = xyz[b, chosen]  # (B, m, 3)
            first = level[0]
            h = nn.functional.linear(xyz[b[..., None], idx] - centre[:, :, None], first.weight[:, :3], first.bias)
            if features is not None:  # (B, m, g, width): W_f f_j of each point, grouped
                h = h + nn.functional.linear(features, first.weight[:, 3:])[b[..., None], idx]
            xyz, features = centre, level[1:](h).max(dim=2).values  # (B, m, 3), (B, m, width)
        return self.global_mlp(torch.cat([xyz, features], dim=-1)).amax(dim=1)


def farthest_points(points: torch.Tensor, m: int) -> torch.Tensor:
    """Farthest-point sampling: indices ``(B, m)`` of ``m`` of the points ``(B, p, 3)`` of each set, starting from its
    first point, each next one the point farthest from those chosen (PointNet++'s sampling of centres).
    """
    B, p, _ = points.shape
    chosen = torch.zeros(B, m, dtype=torch.long, device=points.device)
    nearest = torch.full((B, p), float("inf"), dtype=points.dtype, device=points.device)
    last = points[:, 0]
    for i in range(1, m):
        nearest = torch.minimum(nearest, ((points - last[:, None]) ** 2).sum(-1))
        chosen[:, i] = nearest.argmax(dim=1)
        last = points[torch.arange(B, device=points.device), chosen[:, i]]
    return chosen


#: The networks the trainer knows, by the name stored in a checkpoint's config (``architecture``), and what they read.
ARCHITECTURES = {
    "operatornet": (OperatorNet, "operators"),
    "pointnet": (PointNetAutoencoder, "vertices"),
    "pointnet_stn": (PointNetTransformerAutoencoder, "vertices"),
    "pointnet2": (PointNet2Autoencoder, "vertices"),
}


def build_model(config: dict) -> nn.Module:
    """A network from its ``config()`` (:meth:`OperatorNet.config`, :meth:`PointNetAutoencoder.config`;
    ``architecture`` defaults to ``"operatornet"``, as in older checkpoints).
    """
    config = dict(config)
    architecture = config.pop("architecture", "operatornet")
    if architecture not in ARCHITECTURES:
        raise ValueError(f"unknown architecture {architecture!r}; use one of {list(ARCHITECTURES)}.")
    return ARCHITECTURES[architecture][0](**config)


def _statistics_were_set(state_dict, prefix, *args) -> None:
    """Checkpoints written before the ``statistics_set`` flag existed came from :func:`opnet.train.fit`, which
    always sets the statistics: read them as set.
    """
    if prefix + "input_mean" in state_dict or prefix + "base" in state_dict:
        state_dict.setdefault(prefix + "statistics_set", torch.tensor(True))


def kabsch_torch(X: torch.Tensor, Y: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Rotation ``R`` ``(B, 3, 3)`` and translation ``t`` ``(B, 3)`` minimising ``Σ‖R x + t − y‖²`` (no reflections).

    Computed in float64 without gradient (see :func:`rigid_alignment_loss`).
    """
    with torch.no_grad():
        X64, Y64 = X.detach().double(), Y.detach().double()
        mx, my = X64.mean(1, keepdim=True), Y64.mean(1, keepdim=True)
        U, _, Vt = torch.linalg.svd((X64 - mx).transpose(1, 2) @ (Y64 - my))
        d = torch.sign(torch.linalg.det(Vt.transpose(1, 2) @ U.transpose(1, 2)))
        d = torch.where(d == 0, torch.ones_like(d), d)
        S = torch.diag_embed(torch.stack([torch.ones_like(d), torch.ones_like(d), d], dim=1))
        R = Vt.transpose(1, 2) @ S @ U.transpose(1, 2)
        t = my.squeeze(1) - (R @ mx.transpose(1, 2)).squeeze(2)
    return R.to(X.dtype), t.to(X.dtype)


def rigid_alignment_loss(pred: torch.Tensor, target: torch.Tensor, reduction: str = "mean") -> torch.Tensor:
    """Eq. 9: ``(1/n) Σ_i ‖R(pred_i) − target_i‖²`` after the optimal rigid motion ``R``, per shape.

    ``pred``, ``target``: ``(B, n, 3)``, ``B ≥ 1``. ``reduction="mean"`` averages over the batch (a scalar),
    ``"none"`` returns the ``(B,)`` per-shape values (``d_R`` of each shape). The optimal rotation and
    translation are found by Kabsch (float64
    SVD, no reflections) and then held fixed: since they minimise the loss, the gradient with them fixed is
    the gradient of the minimum (Danskin's theorem), so no gradient flows through the SVD and it stays finite
    even where singular values coincide. Invariant to rigid motions of ``pred``.
    """
    if not isinstance(pred, torch.Tensor) or not pred.is_floating_point():
        raise TypeError(f"pred must be a floating-point tensor (B, n, 3) (the network's output), got {describe(pred)}.")
    if not isinstance(target, torch.Tensor):  # e.g. numpy coordinates, in pred's precision like the loss
        target = torch.as_tensor(real_array("target", target), dtype=pred.dtype, device=pred.device)
    elif target.is_complex() or not target.is_floating_point():
        raise TypeError(f"target must be a floating-point tensor (B, n, 3), got {describe(target)}.")
    if pred.shape != target.shape or pred.ndim != 3 or pred.shape[-1] != 3:
        raise ValueError(f"pred and target must both be (B, n, 3), got {tuple(pred.shape)} and {tuple(target.shape)}.")
    if pred.shape[0] == 0:
        raise ValueError("the batch is empty (B = 0): the loss of no shapes is undefined; pass at least one shape.")
    if reduction not in ("mean", "none"):
        raise ValueError(f"reduction must be 'mean' or 'none', got {reduction!r}.")
    if not (torch.isfinite(pred).all() & torch.isfinite(target).all()):  # one device sync per call, on the hot path
        name = "target" if torch.isfinite(pred).all() else "pred"  # the SVD would fail on it (or give NaN on a GPU)
        raise ValueError(f"{name} contains NaN or infinite coordinates.")
    R, t = kabsch_torch(pred, target)
    aligned = pred @ R.transpose(1, 2) + t[:, None, :]
    per_shape = ((aligned - target) ** 2).sum(-1).mean(-1)
    return per_shape.mean() if reduction == "mean" else per_shape
