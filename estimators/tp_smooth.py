"""Fixed-lag Rauch-Tung-Striebel smoothing of the target-plane tracks' output (``smooth_output``).

The joint tracker (``tp_joint``) is a filter: each frame's state uses the windows up to that
frame. The output is final only ``output_lag_s`` after each frame (``tp_identity``), so the
estimate reported for frame k may use the windows up to frame k + L, L = the lag in frames. This
module gives that estimate: for each frame, the RTS backward pass over the track's own filtered
states from frame k + L (or the track's last frame) down to k,

    C_i = S_i F_i+1^T (S_i+1|i)^-1,    s_i^s = s_i + C_i (s_i+1^s - s_i+1|i),
                                        S_i^s = S_i + C_i (S_i+1^s - S_i+1|i) C_i^T,

with s_i, S_i the walking state after frame i's updates, s_i+1|i, S_i+1|i its prior for the next
frame (after the mode mixing and the prediction) and F_i+1 that prediction's transition. A
person walking through a merge, whose track lagged behind it while the windows were merged, is
put back where the windows after the merge say it was. Only the walking state is smoothed: a
standing person's position is the standing mode's, which has no dynamics to smooth.

A track's chain of frames is cut where its state was changed by anything but the prediction and
the frame's updates (a track located on the click, a take-over, the target put back on the
floor) and where the prediction capped its spreads (the transition no longer relates the two
frames' covariances); each piece is smoothed on its own. The covariances are smoothed with the
means (the internal rows' ``cxx, cxy, cyy`` are the smoothed estimate's, so ``explain_tp_errors``
compares an error with its own spread).
"""
from __future__ import annotations

import numpy as np


def fixed_lag_smooth(s: np.ndarray, S: np.ndarray, s_prior: np.ndarray, S_prior: np.ndarray, F: np.ndarray,
                     lag: int) -> tuple[np.ndarray, np.ndarray]:
    """Fixed-lag RTS smoothed means and covariances of one chain of n frames.

    ``s`` (n, d), ``S`` (n, d, d): the filtered states; ``s_prior`` (n, d), ``S_prior`` (n, d, d)
    and ``F`` (n, d, d): frame i's prior and the transition that gave it from frame i - 1 (row 0
    unused). Returns (n, d) and (n, d, d): frame k's mean and covariance given the frames up to
    min(k + lag, n - 1). ``lag`` 0 returns ``s`` and ``S``; lag >= n - 1 is the fixed-interval
    RTS smoother."""
    s = np.asarray(s, float)
    S = np.asarray(S, float)
    n = len(s)
    if n < 2 or lag <= 0:
        return s.copy(), S.copy()
    # the RTS gains C_i = S_i F_{i+1}^T inv(S_{i+1|i}), i = 0 .. n-2 (solve: S_prior is symmetric)
    C = np.linalg.solve(S_prior[1:], F[1:] @ S[:-1]).transpose(0, 2, 1)
    lag = min(int(lag), n - 1)
    # every frame k's backward pass at once: after step j, cur[k] is frame k + L - j smoothed on the
    # frames up to k + L (the pass of frames near the end starts at the chain's last frame)
    start = np.minimum(np.arange(n) + lag, n - 1)
    cur, cov = s[start].copy(), S[start].copy()
    for j in range(1, lag + 1):
        idx = start - j  # the frame each pass reaches now
        live = idx >= np.arange(n)  # passes not yet at their own frame k
        i = idx[live]
        cur[live] = s[i] + np.einsum("kab,kb->ka", C[i], cur[live] - s_prior[i + 1])
        cov[live] = S[i] + C[i] @ (cov[live] - S_prior[i + 1]) @ C[i].transpose(0, 2, 1)
    return cur, 0.5 * (cov + cov.transpose(0, 2, 1))


def smooth_chains(records: list, lag: int) -> list:
    """Smoothed walking states of every track. ``records``: one per output row, in frame order,
    (track id, s, S, prior, F, cut) - the track's state after the frame's updates, its prior
    (s, S) for the frame and the frame's transition (``tp_joint.JointTracker.predict``; a track's
    first frame has no prior), and whether its chain is cut before this frame (the prediction
    capped the spreads; the track was moved after the frame's updates). Returns the smoothed
    (s, S) of each row (None where a record is None)."""
    out: list = [None if r is None else (r[1], r[2]) for r in records]
    chains: dict = {}  # track id -> row indices of its current chain
    pieces: list = []
    for k, r in enumerate(records):
        if r is None:
            continue
        tid, _, _, prior, F, cut = r
        chain = chains.get(tid)
        if chain is not None and prior is not None and F is not None and not cut:
            chain.append(k)
        else:
            chains[tid] = [k]
            pieces.append(chains[tid])
    for piece in pieces:
        if len(piece) < 2:
            continue
        recs = [records[k] for k in piece]
        eye = np.eye(len(recs[0][1]))  # row 0's prior and transition: unused
        s_prior = np.array([r[3][0] if k else r[1] for k, r in enumerate(recs)])
        S_prior = np.array([r[3][1] if k else eye for k, r in enumerate(recs)])
        F = np.array([r[4] if k else eye for k, r in enumerate(recs)])
        sm, Sm = fixed_lag_smooth(np.array([r[1] for r in recs]), np.array([r[2] for r in recs]), s_prior, S_prior, F, lag)
        for k, v, V in zip(piece, sm, Sm):
            out[k] = (v, V)
    return out
