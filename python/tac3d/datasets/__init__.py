"""Randomized twin datasets (docs/datasets.md, "Randomized datasets"): episodes drawn from a
spec, simulated on a Dask cluster, one zarr group an episode.

- ``open(DIR)``: the complete episodes, each iterating its frames as numpy arrays.
- ``generate(spec, out, episodes, workers=K | scheduler=ADDRESS)``: what ``tac3d dataset
  generate`` runs.
- ``verify(DIR)``: the manifest against the stored arrays.
- ``load_spec(path)``: the parsed spec (``draw(i)``: episode i's parameters and scene).
"""
from .._core import load_dataset_spec as load_spec  # noqa: F401
from .generate import generate  # noqa: F401
from .store import Dataset, Episode, verify  # noqa: F401


def open(folder):  # noqa: A001  (tac3d.datasets.open, as the issue names it)
    """The dataset folder's complete episodes (a Dataset: len, [id], iteration)."""
    return Dataset(folder)


__all__ = ["Dataset", "Episode", "generate", "load_spec", "open", "verify"]
