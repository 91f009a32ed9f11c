"""A process's place in a ``torchrun`` job, read from torchrun's environment variables: plain Python, no torch, so
that ``train.py`` knows its device and seeds before the heavy imports (the model build beside them)."""

from __future__ import annotations

import dataclasses


@dataclasses.dataclass(frozen=True)
class Rank:
    """This process's place in a ``torchrun`` job (rank 0 of 1 without one)."""

    rank: int = 0
    local_rank: int = 0
    world_size: int = 1
    device: str | None = None  # None: resolve --device as usual

    @property
    def is_main(self) -> bool:
        return self.rank == 0

    def seeds(self, seed: int, terrain_seed: int) -> tuple[int, int]:
        """Each rank its own seed (actions, resets) and terrain layout; rank 0 keeps the given ones."""
        return seed + self.rank, terrain_seed + self.rank


def distributed_rank(environ: dict, device: str | None) -> Rank:
    """Read torchrun's WORLD_SIZE / RANK / LOCAL_RANK. Each rank trains its own env batch on ``cuda:LOCAL_RANK``
    (NCCL), or on the CPU with ``device`` "cpu" (Gloo: tests, CI); gradients are averaged, rank 0 logs and saves."""
    try:
        world = int(environ.get("WORLD_SIZE", "1"))
        rank, local = int(environ.get("RANK", "0")), int(environ.get("LOCAL_RANK", "0"))
    except ValueError:
        raise ValueError("WORLD_SIZE, RANK and LOCAL_RANK must be integers (set by torchrun)")
    if world <= 1:
        return Rank(device=device)
    if not 0 <= rank < world or not 0 <= local < world:
        raise ValueError(f"RANK {rank} / LOCAL_RANK {local} must lie in [0, WORLD_SIZE={world})")
    if device == "cpu":
        return Rank(rank, local, world, "cpu")
    if device is not None and not device.startswith("cuda"):
        raise ValueError(f"distributed training runs on cuda (one GPU per rank) or cpu, not on '{device}'")
    return Rank(rank, local, world, f"cuda:{local}")


__all__ = ["Rank", "distributed_rank"]
