"""The sensitivity columns of a Jacobian propagated in parallel threads.

A Jacobian of a shooting map integrates y with Φ = ∂y/∂(z, τ) (8–10 columns) in one compiled
loop, and XLA runs that computation on the one thread that called it: on a 2-core machine an E8
solve, whose models follow one another, leaves the second core idle (measured: 100 % CPU, not
200 %). Given y, the columns are independent (Φ' = g_y Φ + g_τ e_τ, and at a switch of the exact
map the saltation acts column by column), and the step control reads y alone
(:func:`.flow._primal_rms`). So the columns split into blocks, each integrated with its own copy
of y on its own thread: every block takes the same steps and ends at the same y(K_f), and the
joined Φ(K_f) is the one the single computation gives, to round-off. JAX releases the GIL while a
compiled computation runs, so the threads run in parallel; each thread waits for its own block
(dispatched without waiting, the blocks queued on the CPU client and ran one after the other, and
slower: 7–20 s against 8.2 s).

The gain is bounded by what the blocks share: each integrates y, and the primal field with its
linearisation costs far more than a column. E8 at 500 revolutions, the 4×4 → full blend on the
exact map at the path rtol (scratch, idle machine): pass 1 1.37 s; pass 2 with 5 columns 4.93 s,
with 10 columns 6.46 s (0.3 s a column). Side by side (``benchmarks/perturbed.py
--threads-compare``, 4 rounds): two threads 1.15× faster there; 1.28× on the unperturbed
smoothed map (scratch; docs/perturbed-e6-e7-e8.md, "thirty-ninth session").

Written by hand: ``jax.pmap``/``shard_map`` over CPU devices need the device count fixed before
JAX starts (``XLA_FLAGS=--xla_force_host_platform_device_count``), which a library cannot set for
its callers, and would split y's integration the same way.

The thread count: the environment variable ``SPACEOPT_THREADS`` (default 1: the single fused
computation; :func:`spaceopt.config.threads`); the workflow sets it from a job's ``threads``.
"""
from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor
from functools import lru_cache

import jax
import jax.numpy as jnp

@lru_cache(maxsize=None)
def _pool(k: int) -> ThreadPoolExecutor:
    return ThreadPoolExecutor(max_workers=k, thread_name_prefix="spaceopt-columns")


def blocks(Phi0, k: int) -> list:
    """Φ(0) and the τ tangent (1 in Φ's last column, the τ column) split into ``k`` blocks of
    equal width, zero columns padding the last (one compiled block function serves them all)."""
    n_col = Phi0.shape[1]
    width = math.ceil(n_col / k)
    pad = k * width - n_col
    Phi = jnp.pad(Phi0, ((0, 0), (0, pad)))
    tangent = jnp.zeros(k * width).at[n_col - 1].set(1.0)
    return [(Phi[:, i * width:(i + 1) * width], tangent[i * width:(i + 1) * width]) for i in range(k)]


def propagate(propagate_block, Phi0, k: int):
    """``propagate_block(Phi_block, tangent_block)`` → (y_f, Φ_f block, *rest) on each of ``k``
    blocks of Φ(0), in ``k`` threads: (block 0's outputs with the joined Φ_f in place of its block,
    and whether every block succeeded, from each output's last element)."""
    # each thread waits for its own block: dispatched without waiting, the blocks would queue
    # on the CPU client and run one after the other
    outs = list(_pool(k).map(lambda b: jax.block_until_ready(propagate_block(*b)), blocks(Phi0, k)))
    Phif = jnp.concatenate([o[1] for o in outs], axis=1)[:, :Phi0.shape[1]]
    ok = outs[0][-1]
    for o in outs[1:]:
        ok = ok & o[-1]
    return (outs[0][0], Phif, *outs[0][2:-1], ok)
