"""ONNX export of a policy's deterministic action mu(s), normalization included, for deployment
outside Python/torch (ONNX Runtime on the robot's computer)."""

from __future__ import annotations

import io
import warnings
from pathlib import Path

import torch

from learn.policy import ActorCritic, load_checkpoint


class _ActionMean(torch.nn.Module):
    def __init__(self, model: ActorCritic) -> None:
        super().__init__()
        self.model = model

    def forward(self, observation: torch.Tensor) -> torch.Tensor:
        return self.model.action_mean(observation)


def export_onnx(policy_path: str | Path, onnx_path: str | Path) -> Path:
    """Write the policy at `policy_path` as ONNX: input 'observation' (batch, obs), output 'action' (batch, 24)."""
    model = ActorCritic.from_checkpoint(load_checkpoint(policy_path)).eval()
    buffer = io.BytesIO()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # the TorchScript exporter: no onnxscript dependency
        torch.onnx.export(_ActionMean(model), torch.zeros(1, model.observation_size), buffer, input_names=["observation"],
                          output_names=["action"], dynamic_axes={"observation": {0: "batch"}, "action": {0: "batch"}},
                          dynamo=False)
    onnx_path = Path(onnx_path)
    onnx_path.parent.mkdir(parents=True, exist_ok=True)
    onnx_path.write_bytes(buffer.getvalue())
    return onnx_path
