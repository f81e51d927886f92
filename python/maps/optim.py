"""The optimisers, after torch.optim (one parameter group each):

    optimizer = maps.optim.Adam(module.parameters(), lr=1e-3, betas=(0.9, 0.999), eps=1e-8, weight_decay=0.0)
    optimizer = maps.optim.SGD(module.parameters(), lr=0.1, momentum=0.9, dampening=0.0, weight_decay=0.0,
                               nesterov=False)
    optimizer.zero_grad(); loss.backward(); optimizer.step()

`params` is an iterable of maps.Tensors (leaves) or a maps.nn.Module (its parameters). Adam's state_dict() holds its
moments and step counts (maps.nn.save writes it; load_state_dict checks it against the parameters).
"""

from ._maps.optim import SGD, Adam, Optimizer  # noqa: F401  (re-exported)

__all__ = ["Adam", "Optimizer", "SGD"]
