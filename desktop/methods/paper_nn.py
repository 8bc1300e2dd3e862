"""The paper's neural-network calibration (section III.B, eqs. 3-5).

Targets: each raw point is mapped to its nearest point on the sphere of radius
B = median |h| centred on the origin, x_s = x_e B / |x_e| (eq. 3). A network
with two hidden layers of three linear nodes and biases (eq. 5: x_s =
x_e S^-1 R + b) is trained on the pairs with the MSE loss, here by Adam on
mini-batches. Inputs and targets are divided by B so the optimiser sees O(1)
numbers (the paper does not say how it scaled them). The paper's dropout of
2 neurons every 30 epochs is left out: on a purely linear 3-node network it
only perturbs the training, it cannot change the map it converges to.

The trained network is an affine map, returned as (matrix, offset, field), its
matrix the symmetric factor of the network's (the same magnitudes).
"""

import numpy as np


def fit_paper_nn(h, field=None, epochs=60, batch=256, learning_rate=3e-3, seed=0):
    h = np.asarray(h, dtype=float)
    radius = float(np.median(np.linalg.norm(h, axis=1)))
    if not radius > 0:
        raise ValueError("samples have no magnitude")
    x = h / radius
    target = x / np.linalg.norm(x, axis=1, keepdims=True)  # eq. (3) on the unit sphere
    rng = np.random.default_rng(seed)
    # Three linear layers 3->3->3->3, each with a bias.
    params = []
    for _ in range(3):
        params.append(np.eye(3) + rng.normal(0.0, 0.05, (3, 3)))
        params.append(np.zeros(3))
    m = [np.zeros_like(p) for p in params]
    s = [np.zeros_like(p) for p in params]
    beta1, beta2, eps = 0.9, 0.999, 1e-12
    step = 0
    n = len(x)
    for epoch in range(epochs):
        # Cosine decay to 1 % of the initial rate: Adam at a fixed rate keeps
        # rattling around the minimum of this (linear, convex-in-effect) problem.
        rate = learning_rate * (0.01 + 0.99 * 0.5 * (1 + np.cos(np.pi * epoch / epochs)))
        order = rng.permutation(n)
        for start in range(0, n, batch):
            idx = order[start:start + batch]
            xb, tb = x[idx], target[idx]
            a0 = xb
            a1 = a0 @ params[0].T + params[1]
            a2 = a1 @ params[2].T + params[3]
            out = a2 @ params[4].T + params[5]
            d_out = 2.0 * (out - tb) / len(idx)
            grads = [None] * 6
            grads[4] = d_out.T @ a2
            grads[5] = d_out.sum(axis=0)
            d2 = d_out @ params[4]
            grads[2] = d2.T @ a1
            grads[3] = d2.sum(axis=0)
            d1 = d2 @ params[2]
            grads[0] = d1.T @ a0
            grads[1] = d1.sum(axis=0)
            step += 1
            for k in range(6):
                m[k] = beta1 * m[k] + (1 - beta1) * grads[k]
                s[k] = beta2 * s[k] + (1 - beta2) * grads[k] ** 2
                mhat = m[k] / (1 - beta1**step)
                shat = s[k] / (1 - beta2**step)
                params[k] = params[k] - rate * mhat / (np.sqrt(shat) + eps)
    w = params[4] @ params[2] @ params[0]
    c = params[4] @ (params[2] @ params[1] + params[3]) + params[5]
    # y = w x + c on scaled data: h_c = R (w h / R + c) = w (h - b), b = -R w^-1 c
    offset = -radius * np.linalg.solve(w, c)
    out_field = radius if field is None else float(field)
    # The network's map may include a rotation (w = R P, polar decomposition). |w (h - b)| is
    # |P (h - b)| for any rotation R: the symmetric factor P = (w^T w)^(1/2) is the same scalar
    # calibration, in the symmetric positive definite form every record has (shared/calibration.py).
    u, sv, vt = np.linalg.svd(w)
    p = (vt.T * sv) @ vt
    return p * (out_field / radius), offset, out_field
