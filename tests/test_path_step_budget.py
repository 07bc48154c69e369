"""The step cap of a path's propagations relative to the path (chain.PathStepBudget): c times the
steps of the path's last successful Jacobian evaluation, within [MIN_STEPS, max_steps]; off (the
transfer's cap alone) without a factor or before the first success; a failure keeps the cap."""
import numpy as np

from spaceopt.indirect import chain
from spaceopt.indirect.flow import Model


def _shooting(budget):
    return chain.Shooting(Model("lp"), chain.ORBIT_COSTATES, max_steps=50_000, path_step_budget=budget)


def test_the_cap_follows_the_last_successful_evaluation(monkeypatch):
    outcomes = iter([(3000, True), (40_000, False), (100, True), (20_000, True)])
    caps = []

    def fake_shoot(sh, z, tau, prm, rtol, atol):
        caps.append(sh.max_steps)
        steps, ok = next(outcomes)
        return np.zeros(1), np.eye(1), np.zeros(1), steps, ok

    monkeypatch.setattr(chain, "shoot", fake_shoot)
    budget = chain.PathStepBudget(_shooting(4.0))
    for _ in range(4):
        budget.shoot(np.zeros(1), 0.0, {}, 1e-9, 1e-10)
    # the transfer's cap first; 4 x 3000; the failure keeps it; 4 x 100 is raised to MIN_STEPS
    assert caps == [50_000, 12_000, 12_000, chain.PathStepBudget.MIN_STEPS]
    assert budget.shooting().max_steps == 50_000          # 4 x 20 000 is beyond the transfer's cap
    assert budget.shooting() == budget.sh                 # the same compiled programs (max_steps not compared)


def test_without_a_factor_the_transfer_cap_alone(monkeypatch):
    monkeypatch.setattr(chain, "shoot", lambda sh, *a: (None, None, None, 10, True))
    budget = chain.PathStepBudget(_shooting(None))
    budget.shoot(np.zeros(1), 0.0, {}, 1e-9, 1e-10)
    assert budget.shooting() is budget.sh
