"""Reads patrolling_sim's patrol graph files (../shared/data/maps/README.md): vertex count, map
width and height in pixels, resolution, origin; then per vertex its id, x and y in pixels (y from
the bottom), neighbour count and (id, compass letter, cost) per neighbour."""


def read_graph(path):
    """The vertices as (id, x m, y m)."""
    nums = [line.strip() for line in open(path) if line.strip()]
    n, res = int(nums[0]), float(nums[3])
    i, verts = 6, []
    for _ in range(n):
        vid, x, y, k = int(nums[i]), int(nums[i + 1]), int(nums[i + 2]), int(nums[i + 3])
        verts.append((vid, x * res, y * res))
        i += 4 + 3 * k
    return verts
