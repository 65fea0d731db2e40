"""The kinds a ``[probabilistic]`` table names, each with its behaviour: what a realisation computes
(``compute``, :data:`COMPUTATIONS`) and how the points are made (``method``, :data:`METHODS`).

A kind is one object of its registry, by the name the study file gives, looked up once by the table
(``Probabilistic.computation``, ``Probabilistic.method_kind``).  Which study type plans a method's rounds
is ``workflows.study_types.METHOD_STUDY_TYPES`` (running code, keyed by these objects).
"""

from __future__ import annotations

from dataclasses import dataclass

from workflows.fields import StudyError


@dataclass(frozen=True)
class Computation:
    """What each realisation is judged by."""

    name: str
    description: str  # for the reference
    searches: bool  # each realisation's own FOS by the stage's search; else one run at the factor

    def how(self, factor: float) -> str:
        """The report's words for it."""
        return f"its FOS against F = {factor:g}" if self.searches else f"the run at F = {factor:g}"


VERDICT = Computation("verdict", "one strength-reduction run per realisation at `factor`, stable or failed",
                      searches=False)
FOS = Computation("fos", "each realisation's own FOS by the stage's search", searches=True)
COMPUTATIONS = {computation.name: computation for computation in (VERDICT, FOS)}
"""Every computation, by the name ``compute`` gives."""


class Method:
    """How the points of a probabilistic study are made: sampled (a realisation each) or placed."""

    name: str
    description: str  # for the reference
    placed = False  # places its points (``workflows.probabilistic.design_points``): random variables only
    # (unless it takes fields), each point's FOS, no [sweep] and no pf_interval_width
    takes_fields = False  # a placed method that also moves a [random_field]'s standard normal vector

    def check(self, table, n_variables: int) -> None:
        """StudyError where the table's other fields do not suit it (a placed method: the rules above)."""
        if not self.placed:
            return
        if n_variables == 0 and not self.takes_fields:  # (one that takes fields: a [random_field] may vary alone)
            raise StudyError("variables", f"{self.name} needs random variables ([[probabilistic.variables]]); it "
                             "does not take a [random_field] yet (use monte_carlo)")
        if not table.computation.searches:
            raise StudyError("compute", f'{self.name} takes the FOS of each point: give compute = "fos"')
        if table.pf_interval_width is not None:
            raise StudyError("pf_interval_width", f"applies to monte_carlo and latin_hypercube, not {self.name}")
        self.check_budget(table, n_variables)

    def check_budget(self, table, n_variables: int) -> None:
        """StudyError where ``realisations`` cannot hold the points the method needs."""

    def most_searches(self, table, n_variables: int) -> int:
        """The most realisations or FOS searches it makes: ``realisations`` (FORM and subset simulation
        stop sooner once converged)."""
        return table.realisations

    def draw(self, sampler, seed: int, count: int):
        """A sampled method's standard normals of ``count`` realisations (``sampling.Sampler``); a placed
        method places its points instead (``design_points.DesignPoints``)."""
        raise NotImplementedError(f"{self.name} places its points")

    def check_in_study(self, study) -> None:
        """A placed method takes no [sweep], and no [random_field] unless it takes fields."""
        if not self.placed:
            return
        if study.random_field is not None and not self.takes_fields:
            raise StudyError("probabilistic.method", f"{self.name} here takes random variables only, not a "
                             "[random_field] (use monte_carlo or subset_simulation)")
        if study.sweep is not None:
            raise StudyError("probabilistic.method", f"{self.name} with [sweep] is not supported yet")


class MonteCarlo(Method):
    name = "monte_carlo"
    description = "`monte_carlo`"

    def draw(self, sampler, seed: int, count: int):
        """The first ``count`` realisations' standard normals (a stream per realisation)."""
        return sampler.monte_carlo(seed, range(count))


class LatinHypercube(MonteCarlo):
    name = "latin_hypercube"
    description = "`latin_hypercube` (stratified; drawn for its count: extending it is a new design)"

    def draw(self, sampler, seed: int, count: int):
        """``count`` realisations stratified together."""
        return sampler.latin_hypercube(seed, count)


def sorm_searches(n_variables: int) -> int:
    """The FOS searches of SORM's round (``workflows.probabilistic.sorm``): the design point, +- the step along
    each of the n - 1 tangent axes, the four corners of each pair of them, +- the step along the normal:
    1 + 2(n-1)^2 + 2; none for one variable (no tangent plane)."""
    return 0 if n_variables < 2 else 1 + 2 * (n_variables - 1) ** 2 + 2


class Form(Method):
    name = "form"
    description = "`form` (the reliability index by FORM on the FOS: random variables, compute = \"fos\")"
    placed = True

    def check_budget(self, table, n_variables):
        """Two iterations of n + 1 points (and SORM's round, ``sorm``)."""
        needed = 2 * (n_variables + 1)
        sorm = sorm_searches(n_variables) if table.sorm else 0
        if table.realisations < needed + sorm:
            raise StudyError("realisations", f"{self.name} with {n_variables} variables needs at least {needed + sorm} "
                             f"FOS searches (two iterations of n + 1{f', and SORM {sorm}' if sorm else ''}), got "
                             f"{table.realisations}")


class PointEstimate(Method):
    name = "point_estimate"
    description = "`point_estimate` (Rosenblueth's 2^n points: the FOS's mean and std, a screen)"
    placed = True

    def check_budget(self, table, n_variables):
        """The 2^n points."""
        needed = 2**n_variables
        if table.realisations < needed:
            raise StudyError("realisations", f"{self.name} with {n_variables} variables needs at least {needed} FOS "
                             f"searches (2^n points), got {table.realisations}")

    def most_searches(self, table, n_variables):
        """Its 2^n points."""
        return min(2**n_variables, table.realisations)


class SubsetSimulation(Method):
    name = "subset_simulation"
    description = ("`subset_simulation` (a small pf by levels of Markov chains on the FOS: random variables "
                   "and random fields, compute = \"fos\")")
    placed = True
    takes_fields = True

    def check_budget(self, table, n_variables):
        """Whole chains of 1 / p0 states, and room for the first level."""
        chains = table.samples_per_level * table.p0
        if abs(1.0 / table.p0 - round(1.0 / table.p0)) > 1e-9 or abs(chains - round(chains)) > 1e-9:
            raise StudyError("p0", f"1 / p0 and samples_per_level * p0 must be whole numbers (the chains, of 1 / p0 "
                             f"states each), got p0 = {table.p0:g} with samples_per_level = {table.samples_per_level}")
        if table.realisations < table.samples_per_level:
            raise StudyError("realisations", f"subset_simulation needs at least samples_per_level = "
                             f"{table.samples_per_level} FOS searches (its first level), got {table.realisations}")


METHODS: dict[str, Method] = {method.name: method for method in (
    MonteCarlo(), LatinHypercube(), Form(), PointEstimate(), SubsetSimulation())}
"""Every method, by the name ``method`` gives."""


def methods_text() -> str:
    """The reference's words for ``method``: each method's description."""
    descriptions = [method.description for method in METHODS.values()]
    return ", ".join(descriptions[:-1]) + " or " + descriptions[-1]
