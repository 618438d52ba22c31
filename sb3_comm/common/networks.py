"""Small network pieces shared by the policies: per-agent MLPs, inverting gradients, one optimizer
step."""

from __future__ import annotations

import contextlib

import torch as th
from torch import nn
from torch.optim import optimizer as torch_optimizer

__all__ = [
    "MLP",
    "PRECISIONS",
    "AgentMLPs",
    "adam_step",
    "check_precision",
    "clip_gradients",
    "gradient_step",
    "inverting_gradients",
    "mlp",
    "set_precision",
]

PRECISIONS: dict[str, th.dtype | None] = {"float32": None, "bfloat16": th.bfloat16}
"""The arithmetic of the hidden layers (a policy's ``precision``): ``"float32"``, or ``"bfloat16"``
(mixed precision: see :class:`MLP`)."""


class MLP(nn.Sequential):
    """A multi-layer perceptron (:func:`mlp`) whose hidden layers may run in reduced precision.

    With ``hidden_dtype`` None (the default) it is a plain ``nn.Sequential``. With ``th.bfloat16``
    the layers before the output ``Linear`` run under :func:`torch.autocast` (their matrix products
    in bfloat16, from float32 weights cast on each call), and the output layer in float32 on the
    hidden activations cast back: parameters, gradients, optimizer state, outputs and losses stay
    float32. It pays where the processor has bfloat16 arithmetic (AVX-512 BF16, AMX, recent GPUs);
    the training speed it gives is measured by ``benchmarks/train_throughput.py --precisions float32
    bfloat16``.
    """

    hidden_dtype: th.dtype | None = None

    def forward(self, x: th.Tensor) -> th.Tensor:
        if self.hidden_dtype is None:
            return super().forward(x)
        layers = list(self._modules.values())
        with th.autocast(x.device.type, dtype=self.hidden_dtype):
            for layer in layers[:-1]:
                x = layer(x)  # type: ignore[misc]
        return layers[-1](x.float())  # type: ignore[misc]

    def forward_candidates(self, fixed: th.Tensor, candidates: th.Tensor, columns: slice) -> th.Tensor:
        """The network on ``C`` inputs per row that differ only in the columns ``columns``, without
        building them: ``fixed`` ``(*batch, in_dim - k)`` holds every other column of each row (in
        order), ``candidates`` ``(C, *batch, k)`` the ``k`` columns that vary; returns
        ``(C, *batch, out_dim)``, what :meth:`forward` gives on each assembled input, to float
        rounding. The first ``Linear`` splits by columns, ``W x = W_f x_f + W_c x_c``, so its
        product on the fixed columns is made once per row, not once per candidate (GSN-MAX's
        effect search: 17 candidate messages of 4 numbers in rows of 148).

        :param fixed: the columns that every candidate shares.
        :param candidates: the columns that vary, a leading candidate dimension before the rows'.
        :param columns: where the varying columns sit in the input (a contiguous slice).
        """
        layers = list(self._modules.values())
        first = layers[0]
        if not isinstance(first, nn.Linear):
            raise TypeError(f"forward_candidates needs a Linear first layer, got {type(first).__name__}")
        start, stop, _ = columns.indices(first.in_features)
        weight = first.weight
        fixed_weight = th.cat([weight[:, :start], weight[:, stop:]], dim=1)
        context = (
            th.autocast(fixed.device.type, dtype=self.hidden_dtype)
            if self.hidden_dtype is not None
            else contextlib.nullcontext()
        )
        with context:
            x = nn.functional.linear(fixed, fixed_weight, first.bias) + nn.functional.linear(
                candidates, weight[:, start:stop]
            )
            for layer in layers[1:-1]:
                x = layer(x)  # type: ignore[misc]
        return layers[-1](x.float() if self.hidden_dtype is not None else x)  # type: ignore[misc]


def check_precision(precision: str) -> None:
    """A clear error unless ``precision`` is one of :data:`PRECISIONS`."""
    if precision not in PRECISIONS:
        raise ValueError(
            f"precision must be one of {list(PRECISIONS)} (the arithmetic of the networks' hidden layers), "
            f"got {precision!r}"
        )


def set_precision(module: nn.Module, precision: str) -> None:
    """Set the hidden-layer arithmetic of every :class:`MLP` in ``module`` (:data:`PRECISIONS`)."""
    check_precision(precision)
    for sub in module.modules():
        if isinstance(sub, MLP):
            sub.hidden_dtype = PRECISIONS[precision]


def mlp(
    in_dim: int, out_dim: int, net_arch: list[int], activation_fn: type[nn.Module], layer_norm: bool = False
) -> MLP:
    """A multi-layer perceptron ``in_dim -> net_arch... -> out_dim`` (linear output; an :class:`MLP`).

    :param layer_norm: a ``LayerNorm`` after each hidden ``Linear``, before its activation (it
        draws no random numbers: a network is initialised the same with or without it).
    """
    layers: list[nn.Module] = []
    last = in_dim
    for width in net_arch:
        layers.append(nn.Linear(last, width))
        if layer_norm:
            layers.append(nn.LayerNorm(width))
        layers.append(activation_fn())
        last = width
    layers.append(nn.Linear(last, out_dim))
    return MLP(*layers)


class AgentMLPs(nn.Module):
    """One MLP applied to every agent row, or one MLP per agent (``share_parameters=False``).

    Maps ``(batch, n_agents, in_dim)`` to ``(batch, n_agents, out_dim)``.

    :param n_agents: number of agent rows.
    :param in_dim: input size of one row.
    :param out_dim: output size of one row.
    :param net_arch: hidden layer widths.
    :param activation_fn: hidden activation class.
    :param share_parameters: one network for all agents (the role one-hot in the observation
        tells them apart) or one per agent, as in the paper.
    :param layer_norm: hidden layers normalised (:func:`mlp`).
    """

    def __init__(
        self,
        n_agents: int,
        in_dim: int,
        out_dim: int,
        net_arch: list[int],
        activation_fn: type[nn.Module],
        share_parameters: bool = True,
        layer_norm: bool = False,
    ) -> None:
        super().__init__()
        self.n_agents = n_agents
        self.share_parameters = share_parameters
        count = 1 if share_parameters else n_agents
        self.nets = nn.ModuleList(
            [mlp(in_dim, out_dim, net_arch, activation_fn, layer_norm) for _ in range(count)]
        )

    def forward(self, x: th.Tensor) -> th.Tensor:
        """Apply the network(s) row by row."""
        if self.share_parameters:
            batch, n_agents, width = x.shape
            return self.nets[0](x.reshape(batch * n_agents, width)).reshape(batch, n_agents, -1)
        return th.stack([net(x[:, i]) for i, net in enumerate(self.nets)], dim=1)


def inverting_gradients(grad: th.Tensor, value: th.Tensor, low: float = -1.0, high: float = 1.0) -> th.Tensor:
    """Inverting gradients for a bounded output (Hausknecht & Stone, ICLR 2016, eq. 11).

    With ``grad`` = dQ/dp the ascent direction for an output ``p`` in ``[low, high]``::

        grad * (high - p) / (high - low)   where grad > 0
        grad * (p - low) / (high - low)    where grad < 0

    The step shrinks as ``p`` nears the bound it is pushed towards, and reverses once ``p`` is
    past it, so outputs stay in range without a saturating ``tanh``.
    """
    width = high - low
    return th.where(grad > 0, grad * (high - value) / width, grad * (value - low) / width)


def clip_gradients(params: list[th.Tensor], max_norm: float) -> None:
    """Scale the gradients of ``params`` so that their global norm is at most ``max_norm``.

    The same values as ``torch.nn.utils.clip_grad_norm_`` (coefficient ``max_norm / (norm + 1e-6)``,
    applied when below 1), in fewer operations: on the CPU, where reading a number back costs
    nothing, the gradients are only scaled when they must be; on an accelerator the coefficient
    (clamped to 1) is always applied, without a host sync.
    """
    grads = [p.grad for p in params if p.grad is not None]
    if not grads:
        return
    total = th.linalg.vector_norm(th.stack(th._foreach_norm(grads)))
    coefficient = max_norm / (total + 1e-6)
    if total.device.type != "cpu":
        th._foreach_mul_(grads, coefficient.clamp(max=1.0))
    elif coefficient.item() < 1.0:
        th._foreach_mul_(grads, coefficient)


def _plain_fused_adam(optimizer: th.optim.Optimizer) -> bool:
    """Whether ``optimizer.step()`` is exactly one ``torch._fused_adam_`` (or ``_fused_adamw_``) call
    per parameter group, with nothing around it: a fused :class:`torch.optim.Adam` or ``AdamW`` on
    the CPU, float32, no AMSGrad, a number as the learning rate, no step hooks, every parameter with
    a gradient and its state (made at its first step), and ``step`` not replaced on the object (a
    learning-rate scheduler wraps it to count its calls)."""
    if type(optimizer) not in (th.optim.Adam, th.optim.AdamW) or "step" in vars(optimizer):
        return False
    if (
        getattr(optimizer, "grad_scale", None) is not None
        or getattr(optimizer, "found_inf", None) is not None
    ):
        return False  # set by a gradient scaler (mixed precision)
    if optimizer._optimizer_step_pre_hooks or optimizer._optimizer_step_post_hooks:
        return False
    if torch_optimizer._global_optimizer_pre_hooks or torch_optimizer._global_optimizer_post_hooks:
        return False
    for group in optimizer.param_groups:
        if not group.get("fused") or group["amsgrad"] or group["capturable"] or group["differentiable"]:
            return False
        if any(isinstance(value, th.Tensor) for value in (group["lr"], *group["betas"])):
            return False
        for param in group["params"]:
            state = optimizer.state.get(param)
            if param.grad is None or param.grad.is_sparse or not state:
                return False
            if param.device.type != "cpu" or param.dtype != th.float32:
                return False
    return True


def adam_step(optimizer: th.optim.Optimizer) -> None:
    """``optimizer.step()``; for a fused Adam on the CPU (:func:`_plain_fused_adam`), the kernel it
    calls, without the wrapper around it.

    ``Optimizer.step``'s wrapper (profiling, hooks, the compiler's guards, grouping the tensors by
    device) costs about as much as the fused kernel on a small network, twice per agent update
    (``benchmarks/update_time.py`` measures what skipping it saves). The kernel gets the same arguments as in
    ``torch.optim.adam._fused_adam`` (its state steps incremented first), so the parameters and the
    state are the same to the bit (``tests/test_fast_update.py``); any other optimizer, or one this
    does not recognise, takes ``optimizer.step()``.
    """
    if not _plain_fused_adam(optimizer):
        optimizer.step()
        return
    for group in optimizer.param_groups:
        params = group["params"]
        states = [optimizer.state[p] for p in params]
        steps = [state["step"] for state in states]
        th._foreach_add_(steps, 1)
        kernel = th._fused_adamw_ if group.get("decoupled_weight_decay", False) else th._fused_adam_
        kernel(
            params,
            [p.grad for p in params],
            [state["exp_avg"] for state in states],
            [state["exp_avg_sq"] for state in states],
            [],
            steps,
            amsgrad=False,
            lr=group["lr"],
            beta1=group["betas"][0],
            beta2=group["betas"][1],
            weight_decay=group["weight_decay"],
            eps=group["eps"],
            maximize=group["maximize"],
            grad_scale=None,
            found_inf=None,
        )


def gradient_step(optimizer: th.optim.Optimizer, loss: th.Tensor, max_grad_norm: float | None) -> None:
    """One step of ``optimizer`` on ``loss``: zero the gradients, backpropagate, clip their global
    norm to ``max_grad_norm`` (None or 0: no clipping; :func:`clip_gradients`), step
    (:func:`adam_step`)."""
    params = [p for group in optimizer.param_groups for p in group["params"]]
    for param in params:  # optimizer.zero_grad(), without its wrapper
        param.grad = None
    loss.backward()
    if max_grad_norm:
        clip_gradients(params, max_grad_norm)
    adam_step(optimizer)
