"""The body/joint graph (the only module that imports networkx).

Nodes are body indices and ``GROUND``; each joint is an edge (a multigraph,
since two bodies may share several joints). Used for connectivity checks and
to place bodies along a spanning tree before the loops are closed by Newton.
"""

from __future__ import annotations

import networkx as nx

from .elements import GROUND, Model

__all__ = ["body_graph", "bodies_not_connected_to_ground", "spanning_tree_edges"]


def body_graph(model: Model) -> nx.MultiGraph:
    """The undirected multigraph of bodies (nodes) and joints (edges).

    Edge attribute ``joint`` holds the :class:`~mbdsl.model.elements.Joint`.
    """
    g = nx.MultiGraph()
    g.add_node(GROUND)
    g.add_nodes_from(range(len(model.bodies)))
    for j in model.joints:
        g.add_edge(j.first.body, j.second.body, joint=j)
    return g


def bodies_not_connected_to_ground(model: Model) -> list[int]:
    """Indices of bodies with no chain of joints to the ground."""
    g = body_graph(model)
    reach = nx.node_connected_component(g, GROUND)
    return [i for i in range(len(model.bodies)) if i not in reach]


def spanning_tree_edges(model: Model) -> list[tuple[int, int, object]]:
    """Breadth-first tree from the ground: (placed body, new body, joint) triples.

    Bodies not reachable from the ground start their own trees (in index
    order) and appear as ``(None, body, None)``.
    """
    g = body_graph(model)
    out, seen = [], set()
    roots = [GROUND] + list(range(len(model.bodies)))
    for root in roots:
        if root in seen:
            continue
        seen.add(root)
        if root != GROUND:
            out.append((None, root, None))
        for parent, child in nx.bfs_edges(g, root):
            seen.add(child)
            data = g.get_edge_data(parent, child)
            joint = data[min(data)]["joint"]
            out.append((parent, child, joint))
    return out
