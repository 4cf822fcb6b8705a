"""An independent torch transcription of the net of eqs. (10)-(11), paper 004, for checking :mod:`hillchart.nets.lm`'s
compiled forward pass and analytic Jacobian against autograd (torch is a test dependency only)."""

import torch


def torch_forward(theta: torch.Tensor, xn: torch.Tensor, hidden: int, n_outputs: int = 1) -> torch.Tensor:
    """Outputs flattened row-major (n n_out,), layout of :mod:`hillchart.nets.lm`'s module docstring."""
    n_in = xn.shape[1]
    k = n_in * hidden
    w1, b1 = theta[:k].reshape(hidden, n_in), theta[k: k + hidden]
    w2 = theta[k + hidden: k + hidden + n_outputs * hidden].reshape(n_outputs, hidden)
    b2 = theta[k + hidden + n_outputs * hidden:]
    return (torch.sigmoid(xn @ w1.T + b1) @ w2.T + b2).reshape(-1)  # eqs. (10)-(11)
