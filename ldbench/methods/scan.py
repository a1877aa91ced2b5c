"""GPU exclusive prefix sum of a ``uint`` SSBO, in place (``ldbench/methods/glsl/common/scan.glsl``).

The shared building block of every compaction: the linearised arrays' offsets (count → scan → fill),
compacted depth-peeled layers, light-grid cells. Blocks of 1024 elements are scanned by one workgroup
each; the block totals are scanned recursively (one level per factor of 1024) and added back, so a scan
of n elements costs 2·⌈log₁₀₂₄ n⌉ − 1 dispatches. Sums are 32-bit (wrap-around past 2³² − 1).

>>> scan = Scan(gpu)
>>> scan.run(buffer, n)      # buffer[0..n) := exclusive prefix sums; returns nothing (no read-back)
"""
from __future__ import annotations

from ldbench.core.bindings import B
from ldbench.core.errors import LdbenchError
from ldbench.core.gpu import GLSL_DIR

BLOCK = 1024
MAX_X = 65535


def groups_2d(nb: int) -> tuple[int, int]:
    """A 2D dispatch of at least ``nb`` workgroups (x ≤ 65535, GL's guaranteed minimum per dimension);
    shaders number their group ``gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x`` and skip
    the extra ones."""
    if nb <= MAX_X:
        return nb, 1
    y = -(-nb // MAX_X)
    return -(-nb // y), y


class Scan:
    """In-place exclusive scan; temporary block-sum buffers are kept between calls (one per level)."""

    def __init__(self, gpu, res=None, prefix: str = "scan."):
        self.gpu, self.res, self.prefix = gpu, res, prefix
        self.blocks = gpu.compute(GLSL_DIR / "common/scan.glsl", {"SCAN_BLOCKS": 1})
        self.add = gpu.compute(GLSL_DIR / "common/scan.glsl", {"SCAN_ADD": 1})
        self._sums: list = []

    def _sum_buffer(self, level: int, nb: int):
        nbytes = 4 * max(nb, 1)
        while len(self._sums) <= level:
            self._sums.append(None)
        buf = self._sums[level]
        if buf is None or buf.size < nbytes:
            name = f"{self.prefix}sums{level}"
            buf = (self.res.buffer(name, reserve=nbytes) if self.res is not None
                   else self.gpu.ctx.buffer(reserve=nbytes))
            self._sums[level] = buf
        return buf

    def run(self, buffer, n: int, level: int = 0):
        """Exclusive prefix sum of ``buffer[0 .. n)`` (uint32) in place."""
        n = int(n)
        if n < 0 or 4 * n > buffer.size:
            raise LdbenchError(f"scan of {n} elements in a buffer of {buffer.size} bytes")
        if n == 0:
            return
        nb = -(-n // BLOCK)
        sums = self._sum_buffer(level, nb)
        gx, gy = groups_2d(nb)
        buffer.bind_to_storage_buffer(B.SCAN_DATA)
        sums.bind_to_storage_buffer(B.SCAN_SUMS)
        self.blocks["n"].value = n
        self.blocks.run(gx, gy)
        self.gpu.ctx.memory_barrier()
        if nb > 1:
            self.run(sums, nb, level + 1)
            buffer.bind_to_storage_buffer(B.SCAN_DATA)
            sums.bind_to_storage_buffer(B.SCAN_SUMS)
            self.add["n"].value = n
            self.add.run(gx, gy)
            self.gpu.ctx.memory_barrier()

    def release(self):
        if self.res is None:
            for b in self._sums:
                if b is not None:
                    b.release()
        self._sums.clear()
