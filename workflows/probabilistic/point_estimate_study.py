"""The point estimate method (``method = "point_estimate"``, ``workflows.probabilistic.point_estimate``):
Rosenblueth's 2^n points at mean +- std in one round, and the FOS's mean and std from their weights
(``design_points``: what the methods that place their points share).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from workflows.probabilistic import point_estimate
from workflows.probabilistic.design_points import DesignPointOutcome, DesignPoints, DesignPointStudy
from workflows.study import StudyError


@dataclass
class PointEstimateOutcome(DesignPointOutcome):
    """The point estimate's moments of the FOS and its reliability indices (module doc)."""

    pem_mean: float = math.nan
    pem_std: float = math.nan
    beta_normal: float = math.nan  # of a normal FOS
    beta_lognormal: float = math.nan

    @property
    def verdict(self) -> str:
        return (f"point estimate (Rosenblueth, {self.n_searches} points at mean +- std; a screen, no tail): FOS mean "
                f"{self.pem_mean:.4g}, std {self.pem_std:.4g}; beta {self.beta_normal:.3f} (normal FOS), "
                f"{self.beta_lognormal:.3f} (lognormal FOS)")


class PointEstimateStudy(DesignPointStudy):
    """A study with ``[probabilistic]`` and ``method = "point_estimate"`` (module doc)."""

    outcome_type = PointEstimateOutcome

    def make_realisations(self) -> DesignPoints:
        """The 2^n points, with their weights."""
        points = DesignPoints(self.study)
        try:
            weights = point_estimate.weights(points.correlation)
        except ValueError as error:
            raise StudyError("probabilistic.correlation", str(error)) from None
        frozen = [marginal.frozen() for marginal in points.marginals]
        points.add(point_estimate.points(np.array([f.mean() for f in frozen]), np.array([f.std() for f in frozen])))
        self.weights = weights
        return points

    def _method_results(self, result: PointEstimateOutcome, ds, attrs: dict):  # type: ignore[override]
        """The FOS's mean and std and the reliability indices into ``result``, ``ds`` (returned) and ``attrs``."""
        from workflows.output.variables import PROBABILISTIC_FILE as var

        table = self.study.probabilistic
        fos = ds["fos"].values
        result.pem_mean, result.pem_std = point_estimate.moments(fos, self.weights)
        result.beta_normal, result.beta_lognormal = point_estimate.reliability_indices(
            result.pem_mean, result.pem_std, table.factor)
        ds["point_weight"] = var["point_weight"](self.weights)
        result.fos_mean, result.fos_std = result.pem_mean, result.pem_std
        attrs.update(point_estimate_fos_mean=result.pem_mean, point_estimate_fos_std=result.pem_std,
                     reliability_index_normal=result.beta_normal,
                     reliability_index_lognormal=result.beta_lognormal)
        return ds

    def _figure(self, ds) -> Path:
        from workflows.probabilistic.design_point_figures import draw_point_estimate  # matplotlib: on use

        return draw_point_estimate(self.out_dir, ds, self.study.probabilistic.factor)
