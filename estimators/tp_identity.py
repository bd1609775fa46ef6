"""Fixed-lag identity decision of ``target_planes`` (issue 12): who is who after two tracks were ambiguous.

The joint tracker (``tp_joint``) keeps one track per person, but two people who walk close
together share windows, and the tracks that follow them may come out of the encounter on each
other's person. Which track carries which identity (the hand-chosen target's, or a reported id in
multi-person mode) is decided here, after the encounter and a short lag, by the joint likelihood
of the pair's states before and after it, with both assignments kept until then:

- **Ambiguous pair**: two located tracks are ambiguous in a frame when a camera's window is
  explained as both of them merged, or their floor positions are nearer than ``4 radius`` (two
  bodies side by side, each a window width: any nearer and one's window can be taken for the
  other's). An **episode** starts at the first ambiguous frame; each track's *pre* state is its
  filtered state s, S (``[x, y, vx, vy]``, m, m/s) in the frame before (a track born during the
  episode: its first state), refreshed until the pair first comes nearer than ``4 radius`` on
  the floor: in a frame where it is merged in some view (the other views see them apart) to the
  states of the frame before; and, with ``pre_while_apart`` (since the fifty-third session), when
  the pair comes near for the first time, to those of its last frame merged nowhere (within the
  lag after a merged one) if that came later. Who is who is not in doubt yet, and the prediction
  to the decision is that much shorter. (A pair that never comes near keeps the pre states of its
  last merged frame: the frames after the encounter are not pre states.)
- **Decision**: the episode ends at the first frame the pair is not ambiguous, t1 (with
  ``decide_apart``, since the fifty-fourth session: a pair that has been nearer than ``4 radius``
  is not ambiguous once it is that far apart again, even if a view still sees the two merged);
  the decision waits ``lag_s`` more (a pair that becomes ambiguous again within it continues the
  episode), so the *post* states s, S at td = t1 + ``lag_s`` have the lag's windows in them (a
  smoother over the last ``lag_s``). With ``post_path`` (since the fifty-eighth session) a post
  state's velocity is the track's displacement from t1 to td over td - t1, not the filter's
  velocity at td (``post_state``): in the encounter's merged frames no flow updates a track, so
  its velocity after it lags the person it is on (or still carries the other person's, when the
  tracks swapped), while the lag's positions are held by the windows' planes. Both hypotheses are
  scored, identities kept (K) or exchanged (X):

      log L(K) = log N(s_a(td); F s_a^pre, F S_a^pre F^T + Q + S_a(td)) + (the same for b)
      log L(X) = log N(s_b(td); F s_a^pre, F S_a^pre F^T + Q + S_b(td)) + (a with b's prediction)

  F and Q the constant-velocity model over td - t_pre with white acceleration ``decide_accel``
  (the walkers' own, measured on development truth; the tracker's ``accel_sigma`` without it):
  the paper's velocity discrimination over position and velocity together, for the pair. The
  identities are exchanged when log L(X) - log L(K) > ``pair_log_odds`` (Bayes' decision at the
  prior odds of an exchange measured on development truth, ``TargetPlanes.Config``;
  ``EXCHANGE_LOG_ODDS`` = log(0.99 / 0.01), the design's 1 % error level, by default here and in
  the other decisions); otherwise they are kept (a pair
  whose track is gone: the hand-over below). A pair decided while a view still merges the two
  (``decide_apart``) opens a new episode at once, its pre states the decision's post states; kept,
  a track left behind (below) is still looked for from the first episode's pre states, among the
  tracks new since then (``Episode.first_pre``). A pair that has separated when the recording ends,
  its lag not yet passed, is decided at the last frame with the states there are (``finish``).
- **Retroactive relabelling, within the output lag**: the output is final ``output_lag_s`` after
  each frame (at least ``lag_s``). An exchange holds from the frame of the encounter where the
  two tracks were nearest on the floor, no earlier than ``output_lag_s`` before the decision (nor
  than an earlier exchange of either track), else from t1 (``reach``): tracks that swap people
  do so where they cross, and the frames between the crossing and t1 - the two still within a
  body width or two, or merged in some view - follow the winning hypothesis too. With
  ``output_lag_s`` = ``lag_s`` it holds from t1 on, and frames before t1 keep what was tracked.

- **Hand-over (``handover``)**: a pair one of whose tracks ends during the encounter (dropped as
  a duplicate of the other, rejected by the existence test) has nothing left to exchange with,
  yet the survivor may have come out of it on the other person - and the tracker starts a new
  track on its own person. ``lag_s`` after the end, each track confirmed since the encounter
  began (``since_confirmed``; without it, born since; the left-behind decision's candidates
  alike), under its own identity (the gone identity not carried on by ``relink``; the gone track
  once confirmed), is scored with the survivor as the pair's continuation:

      log L(X) = log N(s_sv; F s_gone^pre, ...) + log N(s_new; F s_sv^pre, ...)
      log L(K) = log N(s_sv; F s_sv^pre, ...) + max(log N(s_new; F s_gone^pre, ...),
                                                    log(1 / floor area) + log N(v_new; 0, sigma_v^2 I + S_new[v]))

  (kept: the new track is the gone person found again, or someone new). The new track of the
  largest log L(X) - log L(K) above ``handover_log_odds`` takes the survivor's identity from the
  end on, and the survivor the gone one's. With ``handover_reach`` the survivor's exchange holds
  from the frame where the pair was nearest, as a pair's does (``reach``): the tracks swapped
  people where they met, so the gone track carries the survivor's identity from there to its
  end; without it, from the end.
- **A track left behind (``left_behind``)**: a pair decided without an exchange, one of whose
  tracks g is likelier standing at the decision (mu >= 1/2), may have left g where the two met
  while its person walked on (a window of both, explained as g alone, can draw g's velocity to
  nothing). Each track n confirmed since the encounter began, under its own identity, is scored
  as g's person walked on (``walked_on``: ``found_again``'s walked-on and stood-then-walked-off
  terms, from g's pre state, the stop at g's standing position) against someone new, by n's
  first state, at its birth at a two-camera crossing (``behind_at_birth``; a track with no birth
  state, split off a too-wide window, by its state now): where n began says whose person it is, where its own tracking has taken it
  since says little more (a look-alike setting off behind g's stop would fit the stop-then-walk-off
  term by now). The
  likeliest with positive log-odds waits (``behind``): that g's person has stood on since g became
  likelier standing, at t_s, has probability exp(-(t - t_s) / ``stand_s``), and a track left
  behind stands on anyway, so the log-odds grow by (t - t_s) / ``stand_s``; above
  ``EXCHANGE_LOG_ODDS`` n takes g's identity and g n's, from n's first frame on (no earlier than
  the output lag allows). The wait ends when g walks again or either track ends or changes
  identity.
- **A person found again (multi-person mode, ``relink``)**: a confirmed track that ends (the
  tracker's existence test rejected it, or ``hold_s`` passed unseen) leaves its identity, last
  state s_e, S_e, standing probability mu_e and time. When a track is confirmed for the first
  time, after the end and within ``hold_s`` of it, its state s_n, S_n is
  explained two ways:

      L(walked on) = (1 - p) N(s_n; F s_e, F S_e F^T + Q + S_n)
                     + p N(x_n; x_w, S_w[x] + S_n[x] + (sigma_v a)^2 I) N(v_n; 0, sigma_v^2 I + S_n[v])
      L(someone new) = (1 / floor area) N(v_n; 0, sigma_v^2 I + S_n[v])

  The first term: the person walked on at constant velocity (the prediction above). The second:
  the person stopped where last seen, x_w, S_w the track's state in its last frame with a window
  (a standing person makes no window, so its track coasts on and is often lost then) and walked
  off again, at most the new track's age a (since its birth) ago; p = 1 - (1 - mu_e)
  exp(-dt / ``walk_s``), the chance that a walker stopped within the gap dt (the tracker's
  walking-mode duration). Someone new is anywhere on the floor, at a walking velocity of the
  tracker's new-track spread ``sigma_v``. The likelier explanation is taken (a wrong link and a
  missed one each cost one identity change); of several ended tracks, the likeliest. The new
  track carries the ended identity from the ended track's last frame on (its rows before that,
  while both were reported, keep its own id).
- **A successor (the same, for a track that fell behind its person)**: a track whose windows
  move on without it lingers, and the person gets a second track before the first ends. When a
  confirmed track ends, a track confirmed within ``lag_s`` before and still under its own identity
  takes the ended identity (from the end on) when its first state s_b, S_b is likelier the ended
  track's state at that time, N(s_b; s_e(t_b), S_b + S_e(t_b)), than someone new (as above).
- **The watched track's successor (single-target mode, ``successor_reject``)**: the hand-chosen
  target's track never ends, so when the tracker's existence test rejects it while it is likelier
  walking (it lost its person), a track born at a two-camera crossing while it was recorded, and
  sharing no merged window with it now, is scored as its successor in the same way (its birth
  state against the watched track's state then) and takes the identity from its birth on above
  ``successor_log_odds`` (``_watched_successor``). With ``successor_recent_s`` only a track born
  no earlier than that before the rejection began is a candidate (the existence test rejects a
  walker's track that lost its person within that time, so one born earlier was born while the
  watched track was still on someone: someone else); with ``successor_lagged`` only a track born
  while the watched track had a window of its own in fewer than two cameras.

- **An encounter's ended track waits for its hand-over**: a confirmed track that ended while
  its encounter's other track lives is not found again, nor succeeded, at once: the link is
  scored as above, at its usual time, and kept (the likeliest per ended track, ``deferred``)
  until the encounter's hand-over, which scores the survivor as well as the new track (a
  found-again link alone looks only at the ended track's last state, which the encounter's
  merged windows had already pulled onto the other person or stripped of its velocity). An
  exchange there wins; otherwise, or when the encounter closes with both its tracks gone, the
  deferred link is made (``_release``), if its track still carries its own identity.

``IdentityLag.update`` is called once a frame with the tracks after the tracker's step;
``relabel`` maps (time, internal track id) rows to identities afterwards.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

EXCHANGE_LOG_ODDS = float(np.log(0.99 / 0.01))  # exchange identities only on 99:1 evidence


def merged_with(a, b) -> bool:
    """Whether track ``a`` shares a merged window with track ``b`` in some camera this frame."""
    return any(st == "merged" and str(b.tid) in str(reason).split(",") for st, reason, _ in a.status.values())


def entry_at(history: list, t: float):
    """The entry (t, s, S, ...) a history recorded at frame time ``t``, or None."""
    return next((h for h in history if abs(h[0] - t) < 1e-6), None)


def state_at(history: list, t: float):
    """The state (s, S) a history of (t, s, S, ...) recorded at frame time ``t``, or None."""
    h = entry_at(history, t)
    return None if h is None else (h[1], h[2])


def gauss_loglik(r: np.ndarray, C: np.ndarray) -> float:
    """log N(r; 0, C)."""
    return float(-0.5 * (r @ np.linalg.solve(C, r) + np.linalg.slogdet(2 * np.pi * C)[1]))


@dataclass
class Episode:
    """An open encounter of tracks ``a`` and ``b``: their pre states (s, S, t) and, once they are
    apart, the first frame ``t1`` they were."""

    a: int
    b: int
    pre: dict
    t1: float | None = None
    near: bool = False  # the pair has been nearer than 4 radius (the pre states stay as they were then)
    gone: int | None = None  # the track of the pair that ended during the encounter (``handover``)
    t_end: float | None = None  # when it ended
    dist: list = field(default_factory=list)  # (t, floor distance of the pair) of each frame of the encounter
    apart_pre: dict | None = None  # the states of its last frame merged nowhere, not yet near, since its last merged frame (``pre_while_apart``)
    first_pre: dict | None = None  # the pre states of the encounter this one continues (``decide_apart``: kept, still merged in a view), for ``left_behind``


@dataclass
class IdentityLag:
    """Fixed-lag identity decision (module docstring). ``ident``: internal track id -> identity
    (a new track's identity is its own id); ``events``: (t_from, {internal id: identity}) in
    decision order; ``watch``: None to decide for every pair of confirmed tracks (multi-person
    mode), else the identity whose pairs are decided (the hand-chosen target's)."""

    lag_s: float
    accel_sigma: float
    radius: float
    watch: int | None = None
    ident: dict = field(default_factory=dict)
    events: list = field(default_factory=list)
    episodes: dict = field(default_factory=dict)
    last: dict = field(default_factory=dict)  # internal id -> (s, S, t) of the previous frame
    relink_area: float | None = None  # floor area, m^2: found-again links on (module docstring); None: off
    sigma_v: float = 1.5  # a new person's velocity spread, m/s (the tracker's, for an unknown velocity)
    hold_s: float = 6.0  # an ended track may be found again this long after its end, s
    walk_s: float = 8.0  # mean time a walker walks before stopping, s (the tracker's walking mode)
    born: dict = field(default_factory=dict)  # internal id -> time of its first frame
    hist: dict = field(default_factory=dict)  # internal id -> [(t, s, S)]: its first and those of the last hold_s (found-again links) or lag_s (``post_path``)
    last_mu: dict = field(default_factory=dict)  # internal id -> standing probability in the previous frame
    last_seen: dict = field(default_factory=dict)  # internal id -> (x, S[x]) in its last frame with a window
    ended: dict = field(default_factory=dict)  # internal id -> (s, S, t, mu, (x_w, S_w)) of an ended confirmed track
    links: list = field(default_factory=list)  # (t, new id, ended id, log L(walked on) - log L(someone new)) of each link
    scores: list = field(default_factory=list)  # the same for every ended track a new one was compared with
    pair_log_odds: float = EXCHANGE_LOG_ODDS  # a pair's identities are exchanged above these log-odds (``decide``)
    handover_log_odds: float = EXCHANGE_LOG_ODDS  # a hand-over is made above these (``_hand_over``)
    successor_log_odds: float = EXCHANGE_LOG_ODDS  # the watched track's successor takes its identity above these (``_watched_successor``)
    pre_while_apart: bool = True  # the pre states also refreshed in frames the pair, not yet near, is not ambiguous (``update``)
    decide_apart: bool = False  # (the estimator's default: on) a pair that has been near is decided lag_s after it is apart on the floor, merged in a view or not (``update``)
    carried: dict = field(default_factory=dict)  # pair -> first_pre of the encounter decided this frame while merged in a view (``decide``)
    decide_accel: float | None = None  # white acceleration of the exchange and hand-over predictions (None: accel_sigma)
    area: float | None = None  # floor area, m^2: someone new is anywhere on it (``hand_over``)
    conf_t: dict = field(default_factory=dict)  # internal id -> its first confirmed frame (the ids confirmed so far)
    since_confirmed: bool = False  # (the estimator's default: on) hand-over and left-behind candidates: confirmed, not born, since the encounter's pre states (``_began``)
    handover: bool = False  # a pair whose track ended during the encounter is decided with a new track (module docstring)
    left_behind: bool = False  # a pair's track standing after the encounter may have been left behind (module docstring)
    handover_reach: bool = True  # a hand-over holds from the encounter's nearest approach (``_hand_over``)
    behind_at_birth: bool = True  # a left-behind candidate is scored by its birth state (``walked_on``)
    stand_s: float = 3.0  # mean time a person stands before walking on, s (the tracker's standing mode)
    stand_from: dict = field(default_factory=dict)  # internal id -> first frame of its current spell likelier standing
    behind: dict = field(default_factory=dict)  # standing track id -> (new track id, walked_on log-odds) waiting (``_still_behind``)
    decisions: list = field(default_factory=list)  # every scored decision (``record``), for diagnosis
    deferred: dict = field(default_factory=dict)  # ended id -> (t, track, log-odds) of its likeliest link, waiting for a hand-over
    output_lag_s: float | None = None  # how far back a decision may relabel the output, s (None or less: lag_s)
    post_path: bool = False  # (the estimator's default: on) a pair's post velocities are its tracks' displacements over the lag (``post_state``)
    successor_reject: float | None = None  # existence log-odds below which the watched track has lost its person (``_watched_successor``; None: off)
    watched_hist: list = field(default_factory=list)  # [(t, s, S, own)] of the watched identity's track (``watched_tid``) over the last hold_s; own: the cameras in which it had a window of its own
    watched_tid: int | None = None  # the internal id whose states ``watched_hist`` holds
    successor_lagged: bool = False  # a watched track's successor must be born while it had a window of its own in fewer than two cameras (``_watched_successor``)
    successor_recent_s: float | None = None  # a watched track's successor must be born no earlier than this before its rejection began, s (``_watched_successor``; None: any)
    rejected_from: float | None = None  # the first frame of the watched track's current rejection (``_watched_successor``)
    successor_found_again: bool = False  # a candidate may also be a confirmed track's person found again, one that ended before its birth (``_watched_successor``)
    dropped: dict = field(default_factory=dict)  # internal id -> (s, S, t, mu, (x_w, S_w)) of a confirmed track that ended in the last hold_s (``successor_found_again``)

    @property
    def final_s(self) -> float:
        """How long after a frame the output may still change, s: ``output_lag_s``, at least
        ``lag_s``."""
        return max(self.lag_s, self.output_lag_s or 0.0)

    def record(self, td: float, kind: str, a: int, b: int, llr: float, pre_a, pre_b, post_a, post_b, gone: int | None = None,
               t1: float | None = None, t_from: float | None = None) -> None:
        """Log a scored decision: ``kind`` "pair" (tracks a and b of an encounter, exchanged or
        kept), "handover" (a: the survivor, b: a new track, scored against the gone track's
        pre state ``pre_b``), "left behind" (a: a track of the pair likelier standing, b: a new
        track, scored as its person walked on, ``walked_on``) or "left behind made" (that
        exchange, when its log-odds with the stand's duration pass ``EXCHANGE_LOG_ODDS``) or
        "open" (an encounter still ambiguous at the end, not scored: ``finish``);
        log L(X) - log L(K); pre states (s, S, t) and the tracks at td."""
        self.decisions.append({"t": td, "kind": kind, "a": a, "b": b, "gone": gone, "log_odds": llr, "t1": t1, "t_from": t_from,
                               "t_pre": min(pre_a[2], pre_b[2]), "a_pre": pre_a[0][:2].copy(), "b_pre": pre_b[0][:2].copy(),
                               "a_post": post_a.s[:2].copy(), "b_post": post_b.s[:2].copy()})

    @property
    def log(self) -> list:
        """(td, a, b, log L(X) - log L(K)) of every pair decision."""
        return [(d["t"], d["a"], d["b"], d["log_odds"]) for d in self.decisions if d["kind"] == "pair"]

    @property
    def handovers(self) -> list:
        """The hand-over decisions' records (``record``)."""
        return [d for d in self.decisions if d["kind"] == "handover"]

    def identity(self, tid: int) -> int:
        return self.ident.setdefault(tid, tid)

    def holder(self, identity: int) -> int | None:
        """The internal track carrying ``identity`` now."""
        for tid, i in self.ident.items():
            if i == identity:
                return tid
        return None

    def ambiguous(self, a, b) -> bool:
        if float(np.linalg.norm(a.s[:2] - b.s[:2])) < 4.0 * self.radius:
            return True
        return merged_with(a, b)

    def _candidates(self, tracks):
        loc = [tr for tr in tracks if tr.located]
        if self.watch is None:
            conf = [tr for tr in loc if tr.confirmed]
            return [(a, b) for i, a in enumerate(conf) for b in conf[i + 1:]]
        tgt = self.holder(self.watch)
        ta = next((tr for tr in loc if tr.tid == tgt), None)
        return [] if ta is None else [(ta, b) for b in loc if b.tid != tgt]

    def update(self, t: float, tracks) -> None:
        """One frame: open, extend, close and decide episodes; remember the states."""
        for tr in tracks:
            self.identity(tr.tid)
            self.born.setdefault(tr.tid, t)
            if tr.confirmed:
                self.conf_t.setdefault(tr.tid, t)
        alive = {tr.tid: tr for tr in tracks}
        if self.relink_area is not None:
            self._relink(t, tracks, alive)
        for a, b in self._candidates(tracks):
            key = (min(a.tid, b.tid), max(a.tid, b.tid))
            ep = self.episodes.get(key)
            d_ab = float(np.linalg.norm(a.s[:2] - b.s[:2]))
            apart = d_ab >= 4.0 * self.radius
            amb = self.ambiguous(a, b)
            if amb and apart and self.decide_apart and ep is not None and ep.near and ep.gone is None:
                amb = False  # near before, apart on the floor now: merged views alone do not hold the decision
            if amb:
                if ep is None:
                    pre = {tr.tid: self.last.get(tr.tid, (tr.s.copy(), tr.S.copy(), t)) for tr in (a, b)}
                    self.episodes[key] = ep = Episode(key[0], key[1], pre, near=not apart, first_pre=self.carried.get(key))
                else:
                    ep.t1 = None  # together again within the lag: the same encounter
                    if not apart and not ep.near and ep.apart_pre is not None and ep.gone is None:
                        # coming near for the first time: its last frame merged nowhere came after
                        # its last merged one, and was no more in doubt
                        ep.pre = ep.apart_pre
                    ep.near |= not apart
                    if apart and not ep.near and ep.gone is None and all(k in self.last for k in (a.tid, b.tid)):
                        ep.pre, ep.apart_pre = {k: self.last[k] for k in (a.tid, b.tid)}, None
            elif ep is not None:
                if ep.t1 is None:
                    ep.t1 = t
                if self.pre_while_apart and not ep.near and ep.gone is None:
                    # apart and merged nowhere, not yet near: who is who is not in doubt in this
                    # frame; its states become the pre states if the pair comes near later (a
                    # pair that never does is decided from its last merged frame, as before)
                    ep.apart_pre = {tr.tid: (tr.s.copy(), tr.S.copy(), t) for tr in (a, b)}
            if ep is not None and ep.gone is None:
                ep.dist.append((t, d_ab))
        self.carried = {}
        self._close(t, alive)
        if self.successor_reject is not None and self.watch is not None:
            if self.successor_found_again:
                self._remember_dropped(t, alive)
            self._watched_successor(t, alive)
        self.last = {tr.tid: (tr.s.copy(), tr.S.copy(), t) for tr in tracks}
        self.last_mu = {tr.tid: float(tr.mu) for tr in tracks}
        if self.relink_area is not None or self.post_path:
            # found-again links read the last hold_s, a pair's post state the lag's first frame (t1)
            keep_s = max(self.hold_s if self.relink_area is not None else 0.0, self.lag_s + 1e-6 if self.post_path else 0.0)
            for tr in tracks:
                h = self.hist.setdefault(tr.tid, [])
                h.append((t, tr.s.copy(), tr.S.copy()))
                while len(h) > 2 and t - h[1][0] > keep_s:
                    h.pop(1)  # keep the first state (its birth) and the last keep_s
            for tid in [k for k in self.hist if k not in alive]:
                del self.hist[tid]
        for tr in tracks:
            if tr.seen:
                self.last_seen[tr.tid] = (tr.s[:2].copy(), tr.S[:2, :2].copy())
            if tr.mu >= 0.5:
                self.stand_from.setdefault(tr.tid, t)
            else:
                self.stand_from.pop(tr.tid, None)
        for tid in [k for k in self.last_seen if k not in alive]:
            del self.last_seen[tid]  # read by _just_ended in the frame a track ends, and no later
        if self.behind:
            self._still_behind(t, alive)

    def _relink(self, t: float, tracks, alive: dict) -> None:
        """Remember confirmed tracks that ended since the last frame; give a newly confirmed track
        the identity of the ended one it likelier continues (module docstring)."""
        fresh = self._just_ended(alive)
        self.ended.update(fresh)
        self._successors(t, tracks, list(fresh))
        for tid in [k for k, e in self.ended.items() if t - e[2] > self.hold_s + 1e-9]:
            del self.ended[tid]
        for tr in tracks:
            if self.conf_t.get(tr.tid) != t:
                continue  # not confirmed first in this frame
            held = {self.ident.get(o.tid, o.tid) for o in tracks if o.tid != tr.tid}
            best, best_llr = None, 0.0
            for tid in self.ended:
                if self.ident.get(tid, tid) in held:
                    continue
                llr = self.found_again(t, tr, tid)
                self.scores.append((t, tr.tid, tid, llr))
                if llr > best_llr:
                    best, best_llr = tid, llr
            if best is not None:
                self._link_or_defer(t, tr.tid, best, best_llr, alive)

    def _just_ended(self, alive: dict) -> dict:
        """The confirmed tracks of the last frame that ended since (not in ``alive``): internal id
        -> (s, S, t, mu, (x_w, S_w)), their last state and time, standing probability and last
        position seen (``ended``, ``dropped``)."""
        return {tid: (s, S, t_last, self.last_mu.get(tid, 0.0), self.last_seen.get(tid, (s[:2], S[:2, :2])))
                for tid, (s, S, t_last) in self.last.items() if tid not in alive and tid in self.conf_t}

    def _remember_dropped(self, t: float, alive: dict) -> None:
        """``successor_found_again``: the confirmed tracks that ended since the last frame, their
        last states kept for ``hold_s`` (``_watched_successor``'s alternatives)."""
        for tid, e in self._just_ended(alive).items():
            self.dropped.setdefault(tid, e)
        for tid in [k for k, e in self.dropped.items() if t - e[2] > self.hold_s + 1e-9]:
            del self.dropped[tid]

    def _found_again_log_odds(self, tb: float, sb: np.ndarray, Sb: np.ndarray, area: float) -> float:
        """log of the summed likelihood ratios, against someone new, of a track born at tb in
        state ``sb``, ``Sb`` being the person of a confirmed track that ended before tb (within
        ``hold_s``: ``dropped``), walked on or stopped and set off again (``_continues_state``);
        -inf when there is none."""
        out = -np.inf
        for s, S, t_last, mu, stop_at in self.dropped.values():
            if t_last <= tb + 1e-9:
                out = float(np.logaddexp(out, self._continues_state(tb, sb, Sb, 0.0, (s, S, t_last), mu, stop_at, area)))
        return out

    def _watched_successor(self, t: float, alive: dict) -> None:
        """Single-target mode: the watched identity's track, which is never dropped, rejected by
        the existence test (log-odds below ``successor_reject``) while likelier walking has lost
        its person (a walker makes windows; a standing person's track, likelier standing, is left
        alone). Its person may have a track of its own by then: one born while this one lagged
        (a successor, as ``_successors`` scores one in multi-person mode). Each confirmed track
        under its own identity that was born at a two-camera crossing while the watched track was
        recorded (with ``successor_recent_s``, no earlier than that before the first frame of
        this rejection; with ``successor_lagged``, while it had a window of its own in fewer than
        two cameras), and that shares no merged window with it this frame (the tracker holds both
        people there; a rejection in a merge may be the merge's: a look-alike born beside the
        target and walking past it as it stops), is scored as its successor, its birth state
        against the watched track's state then, N(s_b; s_w(t_b), S_b + S_w(t_b)), against
        someone new; the likeliest above
        ``successor_log_odds`` takes the watched identity from its birth on (no earlier than the
        output lag allows), and the rejected track is then an ordinary one."""
        g = self.holder(self.watch)
        tg = alive.get(g)
        if tg is None:
            return
        if g != self.watched_tid:
            self.watched_hist, self.watched_tid, self.rejected_from = [], g, None
        self.watched_hist = [h for h in self.watched_hist if t - h[0] <= self.hold_s + 1e-9]
        own = sum(1 for st, _, _ in tg.status.values() if st == "tracking")
        self.watched_hist.append((t, tg.s.copy(), tg.S.copy(), own))
        if tg.exist >= self.successor_reject or tg.mu >= 0.5 or not self.area:
            self.rejected_from = None
            return
        if self.rejected_from is None:
            self.rejected_from = t
        best, best_llr = None, self.successor_log_odds
        for tid, tr in alive.items():
            if tid == g or not tr.confirmed or self.ident.get(tid, tid) != tid or tr.born is None or merged_with(tg, tr):
                continue  # (merged with it now: the two share windows, and the rejection may be the merge's)
            tb, sb, Sb = tr.born
            at = entry_at(self.watched_hist, tb)
            if at is None:
                continue
            _, sw, Sw, own_at_birth = at
            if self.successor_lagged and own_at_birth >= 2:
                continue  # the watched track was on someone, seen in two views, when this one was born beside it
            if self.successor_recent_s is not None and tb < self.rejected_from - self.successor_recent_s - 1e-9:
                continue  # born before the watched track can have lost its person: someone else
            llr = self._successor_log_odds(sb, Sb, sw, Sw, self.area)
            if self.successor_found_again:
                # someone else: someone new, or a person whose track ended before (equal odds)
                llr -= float(np.logaddexp(0.0, self._found_again_log_odds(tb, sb, Sb, self.area)))
            self.record(t, "successor", g, tid, llr, (sw, Sw, tb), (sb, Sb, tb), tg, tr, gone=g)
            if llr > best_llr:
                best, best_llr = tid, llr
        if best is not None:
            self._exchange(max(self.born.get(best, t), self._not_before(t, (g, best))), g, best)
            self.watched_hist = []

    def _link_or_defer(self, t: float, tid: int, ended: int, llr: float, alive: dict) -> None:
        """``_link``, unless ``ended`` ended in an encounter whose other track lives: then the
        link waits for that encounter's hand-over (the likeliest proposal kept), which may
        exchange instead."""
        if any(ended in key and any(k in alive for k in key if k != ended) for key in self.episodes):
            if llr > self.deferred.get(ended, (None, None, -np.inf))[2]:
                self.deferred[ended] = (t, tid, llr)
            return
        self._link(t, tid, ended, llr)

    def found_again(self, t: float, tr, tid: int) -> float:
        """log L(walked on) - log L(someone new) of track ``tr`` as the ended track ``tid``'s
        person found again (module docstring, "A person found again")."""
        s, S, t_last, mu, (xw, Sw) = self.ended[tid]
        return self._continues(t, tr, (s, S, t_last), mu, (xw, Sw), self.relink_area)

    def _continues(self, t: float, tr, pre, mu: float, stop_at, area: float, accel: float | None = None) -> float:
        """log L(track ``tr`` at t is the person of state ``pre`` (s, S, t0), standing probability
        ``mu`` then) - log L(``tr`` is someone new, anywhere on ``area`` m^2 at a walker's
        velocity): ``_continues_state`` with the track's state and its age at t."""
        return self._continues_state(t, tr.s, tr.S, t - self.born.get(tr.tid, t), pre, mu, stop_at, area, accel)

    def _continues_state(self, t: float, x: np.ndarray, X: np.ndarray, age: float, pre, mu: float, stop_at, area: float,
                         accel: float | None = None) -> float:
        """``_continues`` for a track's state ``x``, ``X`` at t, ``age`` s after its birth: the
        person walked on at constant velocity (white acceleration ``accel``, default
        ``accel_sigma``), or stopped within t - t0 (a walker stops after ``walk_s`` on average) at
        ``stop_at`` (x, S[x]) and walked off from there at most ``age`` ago."""
        s, S, t0 = pre
        xw, Sw = stop_at
        moving = self._walking(x, X)
        new = float(-np.log(area)) + moving
        dt = t - t0
        p, C = self._predict(s, S, dt, accel)
        stop = 1.0 - (1.0 - mu) * float(np.exp(-dt / self.walk_s))
        walked = np.log(max(1.0 - stop, 1e-300)) + gauss_loglik(x - p, C + X)
        stood = np.log(max(stop, 1e-300)) + moving + gauss_loglik(
            x[:2] - xw, Sw + X[:2, :2] + (self.sigma_v * age) ** 2 * np.eye(2))
        return float(np.logaddexp(walked, stood)) - new

    def _successors(self, t: float, tracks, fresh: list) -> None:
        """Confirmed tracks that ended this frame, each given to a successor (module docstring): a
        track confirmed within ``lag_s`` and still under its own identity, whose first state is
        likelier the ended track's state at that time than someone new."""
        held = {self.ident.get(o.tid, o.tid) for o in tracks}
        for e in fresh:
            if e not in self.ended or self.ident.get(e, e) in held:
                continue
            best, best_llr = None, 0.0
            for y in tracks:
                c = self.conf_t.get(y.tid, t)  # confirmed in an earlier frame, within lag_s
                if not y.confirmed or self.ident.get(y.tid, y.tid) != y.tid or c >= t or t - c > self.lag_s + 1e-9:
                    continue
                hy, he = self.hist.get(y.tid), self.hist.get(e)
                if not hy or not he:
                    continue
                tb, sb, Sb = hy[0]
                at = state_at(he, tb)
                if at is None:
                    continue
                se, Se = at
                llr = self._successor_log_odds(sb, Sb, se, Se, self.relink_area)
                self.scores.append((t, y.tid, e, llr))
                if llr > best_llr:
                    best, best_llr = y.tid, llr
            if best is not None:
                self._link_or_defer(t, best, e, best_llr, {o.tid: o for o in tracks})

    def _successor_log_odds(self, sb: np.ndarray, Sb: np.ndarray, se: np.ndarray, Se: np.ndarray, area: float) -> float:
        """log N(s_b; s_e, S_b + S_e) - log L(someone new): a track's birth state ``sb``, ``Sb`` as
        the state ``se``, ``Se`` of the track it succeeds at that time, against someone new anywhere
        on ``area`` m^2 at a walker's velocity (``_successors``, ``_watched_successor``)."""
        return gauss_loglik(sb - se, Sb + Se) - (float(-np.log(area)) + self._walking(sb, Sb))

    def _walking(self, s: np.ndarray, S: np.ndarray) -> float:
        """log N(v; 0, sigma_v^2 I + S[v]): a track's velocity as a walker's whose direction and
        pace are unknown (someone new, or someone setting off from where they stood)."""
        return gauss_loglik(s[2:], self.sigma_v**2 * np.eye(2) + S[2:, 2:])

    def _link(self, t: float, tid: int, ended: int, llr: float) -> None:
        """Track ``tid`` carries the identity of the ended track ``ended`` from that one's last
        frame on."""
        ident = self.ident.get(ended, ended)
        self.ident[tid] = ident
        self.events.append((self.ended[ended][2] + 1e-6, {tid: ident}))
        self.links.append((t, tid, ended, llr))
        del self.ended[ended]

    def _predict(self, s, S, dt, accel: float | None = None):
        """Constant velocity over dt with white acceleration ``accel`` (default ``accel_sigma``)."""
        F = np.eye(4)
        F[0, 2] = F[1, 3] = dt
        q = (self.accel_sigma if accel is None else accel) ** 2
        Q = q * np.kron(np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]]), np.eye(2))
        return F @ s, F @ S @ F.T + Q

    @property
    def walker_accel(self) -> float:
        """The white acceleration of the decisions' walker model (``decide_accel``, else ``accel_sigma``)."""
        return self.accel_sigma if self.decide_accel is None else self.decide_accel

    def post_state(self, tr, t1: float | None, td: float) -> tuple[np.ndarray, np.ndarray]:
        """A pair's post state at td: the track's filtered state, or with ``post_path`` its
        position at td and, for velocity, its displacement since t1 over td - t1 (the lag's
        positions smoothed, not the filter's velocity, which lags a walker whose windows were
        merged: no flow updates it there); covariance from the two positions' (taken
        independent), with the cross term of the shared end."""
        if not self.post_path or t1 is None or td - t1 < 0.5 * self.lag_s:
            return tr.s, tr.S
        then = state_at(self.hist.get(tr.tid, []), t1)
        if then is None:
            return tr.s, tr.S
        dt = td - t1
        x1, C1 = then[0][:2], then[1][:2, :2]
        Cd = tr.S[:2, :2]
        s = np.r_[tr.s[:2], (tr.s[:2] - x1) / dt]
        S = np.block([[Cd, Cd / dt], [Cd / dt, (C1 + Cd) / dt**2]])
        return s, S

    def exchange_log_odds(self, td: float, ep: Episode, ta, tb) -> float:
        """log L(X) - log L(K) of the module docstring (with ``post_path``, the post states of
        ``post_state``)."""
        pa, pb = (self._predict(ep.pre[k][0], ep.pre[k][1], td - ep.pre[k][2], self.walker_accel) for k in (ep.a, ep.b))
        (sa, Sa), (sb, Sb) = self.post_state(ta, ep.t1, td), self.post_state(tb, ep.t1, td)
        keep = gauss_loglik(sa - pa[0], pa[1] + Sa) + gauss_loglik(sb - pb[0], pb[1] + Sb)
        swap = gauss_loglik(sb - pa[0], pa[1] + Sb) + gauss_loglik(sa - pb[0], pb[1] + Sa)
        return swap - keep

    def decide(self, td: float, ep: Episode, ta, tb, alive: dict) -> None:
        if not (ta.confirmed and tb.confirmed):
            return
        llr = self.exchange_log_odds(td, ep, ta, tb)
        t_from = self.reach(td, ep, ep.t1, (ep.a, ep.b))
        self.record(td, "pair", ep.a, ep.b, llr, ep.pre[ep.a], ep.pre[ep.b], ta, tb, t1=ep.t1, t_from=t_from)
        if llr <= self.pair_log_odds:
            if self.decide_apart and merged_with(ta, tb):
                # decided while still merged in a view: the encounter goes on from here (``update``)
                self.carried[(ep.a, ep.b)] = ep.first_pre or ep.pre
            if self.left_behind:
                self._left_behind(td, ep, alive)
            return
        self._exchange(t_from, ep.a, ep.b)

    def _exchange(self, t_from: float, a: int, b: int) -> None:
        """Tracks a and b exchange identities from ``t_from`` on; their open encounters are closed
        (they were scored with the old identities)."""
        ia, ib = self.identity(a), self.identity(b)
        self.ident[a], self.ident[b] = ib, ia
        self.events.append((t_from, {a: ib, b: ia}))
        for key in [k for k in self.episodes if a in k or b in k]:
            del self.episodes[key]

    def _release(self, gone: int, alive: dict) -> None:
        """The link deferred for ``gone`` (``_link_or_defer``), now that its encounter is decided
        without an exchange: made when its track is alive, still under its own identity, and the
        gone identity not carried on otherwise."""
        prop = self.deferred.pop(gone, None)
        if prop is None or gone not in self.ended:
            return
        t, tid, llr = prop
        held = {self.ident.get(k, k) for k in alive}
        if tid in alive and self.ident.get(tid, tid) == tid and self.ident.get(gone, gone) not in held:
            self._link(t, tid, gone, llr)

    def _close(self, t: float, alive: dict, end: bool = False) -> None:
        """Episodes whose lag has passed at t: a pair apart since t1 is decided, a pair one of
        whose tracks has ended is handed over; one whose track ends now waits its lag for the
        hand-over. ``end`` (the recording's last frame, ``finish``): the lag counts as passed."""
        def due(t0: float) -> bool:
            return end or t - t0 >= self.lag_s - 1e-9

        for key, ep in list(self.episodes.items()):
            if self.episodes.get(key) is not ep:
                continue  # closed by a decision earlier in this loop (its tracks' other encounters)
            if ep.gone is not None:
                if due(ep.t_end):
                    del self.episodes[key]
                    self.hand_over(t, ep, alive)
            elif ep.a not in alive or ep.b not in alive:
                if ep.a in alive or ep.b in alive:
                    ep.gone, ep.t_end = (ep.a if ep.a not in alive else ep.b), t  # decided with a new track, lag_s on
                else:
                    del self.episodes[key]  # a track of the pair is gone: nothing to exchange
                    for k in key:
                        self._release(k, alive)
            elif ep.t1 is not None and due(ep.t1):
                del self.episodes[key]
                self.decide(t, ep, alive[ep.a], alive[ep.b], alive)

    def finish(self, tracks) -> None:
        """The end of the recording: what still waits for its lag is decided with the states there
        are, as a fixed-lag smoother ends - an encounter whose pair has separated (t1 passed, the
        lag not) is decided (``decide``) and a pending hand-over made or refused (``hand_over``),
        both at the last frame; then links still waiting for a hand-over that will not come are
        made (``_release``). An encounter still ambiguous at the end is left as tracked (its pair
        has not come apart) and logged, unscored, as kind "open" (log-odds NaN), so that an
        encounter never decided can be found and labelled (``scripts/measure_tp_identity.py``)."""
        alive = {tr.tid: tr for tr in tracks}
        if self.last:
            t_end = max(v[2] for v in self.last.values())
            self._close(t_end, alive, end=True)
            for ep in self.episodes.values():
                if ep.gone is None and ep.a in alive and ep.b in alive:
                    self.record(t_end, "open", ep.a, ep.b, float("nan"), ep.pre[ep.a], ep.pre[ep.b], alive[ep.a], alive[ep.b])
        for gone in list(self.deferred):
            self._release(gone, alive)

    def hand_over(self, td: float, ep: Episode, alive: dict) -> None:
        """``_hand_over``; then, without an exchange, the gone track's deferred link."""
        if not self._hand_over(td, ep, alive):
            self._release(ep.gone, alive)
        else:
            self.deferred.pop(ep.gone, None)

    def _hand_over(self, td: float, ep: Episode, alive: dict) -> bool:
        """An encounter one of whose tracks ended (``gone``), ``lag_s`` after its end: the survivor
        and each track confirmed since the encounter began (a person the tracker found again)
        are scored as the pair's continuation, kept (the survivor continues its own pre state,
        the new track the gone one's or is someone new) against exchanged, as
        ``exchange_log_odds``; the new track
        of the largest log-odds exchanges when they exceed ``handover_log_odds``: the new track
        takes the survivor's identity from the end on, and the survivor the gone track's - from
        the pair's nearest approach (``reach``, the gone track carrying the survivor's identity
        until its end) with ``handover_reach``, else from the end."""
        sv = ep.b if ep.gone == ep.a else ep.a
        if sv not in alive or not alive[sv].confirmed:
            return False
        if self.ident.get(ep.gone, ep.gone) in {self.ident.get(k, k) for k in alive}:
            return False  # the gone identity was found again (``relink``)
        if ep.gone not in self.conf_t:
            return False  # a track never confirmed (a fragment's): no one to hand over
        ts = alive[sv]
        t_pre = min(v[2] for v in ep.pre.values())
        pg = self._predict(*ep.pre[ep.gone][:2], td - ep.pre[ep.gone][2], self.walker_accel)
        ps = self._predict(*ep.pre[sv][:2], td - ep.pre[sv][2], self.walker_accel)
        best, best_llr = None, self.handover_log_odds
        for tid, tr in alive.items():
            if tid == sv or not tr.confirmed or self.ident.get(tid, tid) != tid or self._began(tid) < t_pre - 1e-9:
                continue
            # kept: the survivor continues itself, the new track the gone one, or someone new
            new = float(-np.log(self.area)) + self._walking(tr.s, tr.S) if self.area else -np.inf
            keep = gauss_loglik(ts.s - ps[0], ps[1] + ts.S) + max(gauss_loglik(tr.s - pg[0], pg[1] + tr.S), new)
            swap = gauss_loglik(ts.s - pg[0], pg[1] + ts.S) + gauss_loglik(tr.s - ps[0], ps[1] + tr.S)
            llr = swap - keep
            self.record(td, "handover", sv, tid, llr, ep.pre[sv], ep.pre[ep.gone], ts, tr, gone=ep.gone, t1=ep.t_end)
            if llr > best_llr:
                best, best_llr = tid, llr
        if best is None or not self.handover:
            return False  # (without ``handover`` the pairs are scored, for diagnosis, and never exchanged)
        i_sv, i_gone = self.identity(sv), self.identity(ep.gone)
        self.ident[sv], self.ident[best] = i_gone, i_sv
        if self.handover_reach:
            # the pair swapped where they met: from there, as a pair's exchange (the gone
            # track's rows until its end), and the new track from the end
            self.events.append((self.reach(td, ep, ep.t_end, (sv, ep.gone)), {sv: i_gone, ep.gone: i_sv}))
            self.events.append((ep.t_end, {best: i_sv}))
        else:
            self.events.append((ep.t_end, {sv: i_gone, best: i_sv}))
        self.ended.pop(ep.gone, None)  # its identity is carried on: not to be found again
        for key in [k for k in self.episodes if sv in k or best in k]:
            del self.episodes[key]
        return True

    def _began(self, tid: int) -> float:
        """When track ``tid`` counts as new for a hand-over or a left-behind decision: its first
        frame, or with ``since_confirmed`` its first confirmed one."""
        return (self.conf_t if self.since_confirmed else self.born).get(tid, -np.inf)

    def walked_on(self, td: float, tr, pre, tg) -> float:
        """log L(track ``tr`` is the person of the pre state ``pre`` (s, S, t), who walked on) -
        log L(``tr`` is someone new), as ``found_again`` scores an ended track's person (walking
        at the pre state), with the decisions' walker model and the stop at the standing track
        ``tg`` (where the tracker holds that person standing). With ``behind_at_birth`` a track
        born at a two-camera crossing (``tr.born``: t_b, s_b, S_b) is scored at its birth: the
        pre state predicted to t_b against s_b, or the stop at most its age then (none) before,
        as ``_successors`` scores a successor; a track without a birth state (split off a
        too-wide window) by its state now."""
        stop_at = (tg.xs, tg.Ps) if tg.xs is not None else (tg.s[:2], tg.S[:2, :2])
        if self.behind_at_birth and tr.born is not None:
            tb, sb, Sb = tr.born
            return self._continues_state(tb, sb, Sb, tb - self.born.get(tr.tid, tb), pre, 0.0, stop_at, self.area, self.walker_accel)
        return self._continues(td, tr, pre, 0.0, stop_at, self.area, self.walker_accel)

    def _left_behind(self, td: float, ep: Episode, alive: dict) -> None:
        """An encounter decided without an exchange, one of whose tracks is likelier standing at
        the decision (mu >= 1/2): its person may have stopped where the two met, or walked on
        with its track left behind (a window of both, explained as one of them, can draw that
        one's velocity to nothing). Each track confirmed since the encounter began, under its own
        identity, is scored as that person walked on (``walked_on``) against someone new; the
        likeliest with positive log-odds waits for the stand's duration to decide
        (``_still_behind``, called at once: above ``EXCHANGE_LOG_ODDS`` already, it exchanges)."""
        if not self.area:
            return
        pre = ep.first_pre or ep.pre
        t_pre = min(v[2] for v in pre.values())
        for g in (ep.a, ep.b):
            tg = alive.get(g)
            if tg is None or tg.mu < 0.5:
                continue
            best, best_llr = None, -np.inf
            for tid, tr in alive.items():
                if tid in (ep.a, ep.b) or not tr.confirmed or self.ident.get(tid, tid) != tid or self._began(tid) < t_pre - 1e-9:
                    continue
                llr = self.walked_on(td, tr, pre[g], tg)
                self.record(td, "left behind", g, tid, llr, pre[g], pre[g], tg, tr, gone=g, t1=ep.t1)
                if llr > best_llr:
                    best, best_llr = tid, llr
            if best is not None and best_llr > 0.0:
                self.behind[g] = (best, best_llr)
                self._still_behind(td, alive)
                if g not in self.behind:
                    return

    def _still_behind(self, t: float, alive: dict) -> None:
        """Pending left-behind decisions (``_left_behind``), each frame: that the standing track's
        person has stood on since t_s, when the track became likelier standing, has probability
        exp(-(t - t_s) / ``stand_s``) (the tracker's standing mode; its own windows would have woken
        it); a track left behind stands on anyway. So the log-odds grow by (t - t_s) / ``stand_s``;
        the identities are exchanged when they exceed ``EXCHANGE_LOG_ODDS``, from the new track's
        first frame on (no earlier than ``_not_before`` allows). Dropped when the standing track
        is no longer likelier standing (a window of its own woke it), or either track is gone or
        has changed identity."""
        for g, (n, llr) in list(self.behind.items()):
            tg, tn = alive.get(g), alive.get(n)
            if tg is None or tn is None or tg.mu < 0.5 or self.ident.get(n, n) != n:
                del self.behind[g]
                continue
            odds = llr + (t - self.stand_from.get(g, t)) / self.stand_s
            if odds <= EXCHANGE_LOG_ODDS:
                continue
            del self.behind[g]
            self.record(t, "left behind made", g, n, odds, (tg.s, tg.S, t), (tn.s, tn.S, t), tg, tn, gone=g)
            self._exchange(max(self.born.get(n, t), self._not_before(t, (g, n))), g, n)

    def reach(self, td: float, ep: Episode, t_last: float, tids) -> float:
        """When a decision at ``td`` takes effect: the frame of the pair's nearest approach in the
        encounter, no earlier than ``output_lag_s`` before td (what the output has not yet
        reported) nor than an earlier decision on these tracks, no later than ``t_last``."""
        lo = self._not_before(td, tids)
        cand = [(d, t) for t, d in ep.dist if lo - 1e-9 <= t <= t_last + 1e-9]
        return min(cand)[1] if cand else t_last

    def _not_before(self, td: float, tids) -> float:
        """The earliest time a decision at ``td`` on tracks ``tids`` may relabel: ``output_lag_s``
        (at least ``lag_s``) before td, and not before an earlier decision on these tracks."""
        return max([td - self.final_s] + [t0 for t0, ch in self.events if any(k in ch for k in tids)])

    def relabel(self, t: np.ndarray, tid: np.ndarray) -> np.ndarray:
        """Identity of each output row (time ``t``, internal track ``tid``): its own id, changed
        by every exchange from its t_from on."""
        out = np.asarray(tid).copy()
        t = np.asarray(t, float)
        for t_from, change in self.events:
            later = t >= t_from - 1e-9
            for k, ident in change.items():
                out[later & (np.asarray(tid) == k)] = ident
        return out
