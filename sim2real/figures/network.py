"""A picture of an evolved network, drawn as the thesis (seed 002) draws its hierarchies.

Inputs on the left, outputs on the right, hidden nodes in columns by how many links they
are from an input.  A link's width is its weight's size and its colour the weight's sign;
links that run back (recurrent) arc, self-loops circle their node.  Hidden nodes take their
module's colour; the modules switched off (``--disable-module``) are greyed with their links.
The layout is networkx's (``multipartite_layout``); the drawing matplotlib's.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from sim2real.controller.file import Controller
from sim2real.errors import BipedError
from sim2real.figures import pyplot, save_figure

EXCITATORY, INHIBITORY, OFF = "tab:red", "tab:blue", "0.8"
MODULE_COLOURS = ("tab:green", "tab:purple", "tab:orange", "tab:brown", "tab:pink", "tab:olive", "tab:cyan")
BIAS_NAMES = ("bias", "side")  # the two bias nodes: 1 in both networks; +1 right, -1 left


def _networkx() -> Any:
    try:
        import networkx
    except ImportError as exc:
        raise BipedError("drawing a network needs networkx: pip install 'servo-biped-evolve[plot]'") from exc
    return networkx


def network_graph(controller: Controller, disabled_modules: tuple[str, ...] = ()) -> Any:
    """The controller's network as a ``networkx.DiGraph``: nodes with ``kind`` (input, bias,
    output, hidden), ``label``, ``module`` (hidden: its index) and ``layer`` (column); edges
    with ``weight``, ``module``, ``recurrent`` and ``enabled`` (its module is on)."""
    nx = _networkx()
    graph = nx.DiGraph()
    n_in, n_out = len(controller.inputs), len(controller.outputs)
    for i, name in enumerate(controller.inputs):
        graph.add_node(i, kind="input", label=name, module=None)
    for b, name in enumerate(BIAS_NAMES):
        graph.add_node(n_in + b, kind="bias", label=name, module=None)
    first_output = n_in + len(BIAS_NAMES)
    for o, name in enumerate(controller.outputs):
        graph.add_node(first_output + o, kind="output", label=name, module=None)
    for node, module in controller.hidden:
        graph.add_node(node, kind="hidden", label=str(node), module=module)
    off = {controller.modules.index(m) for m in disabled_modules}
    for src, dst, weight, module in controller.connections:
        graph.add_edge(src, dst, weight=weight, module=module, enabled=module not in off)

    # columns: a hidden node one more than its shortest path of links from an input or bias
    sources = [n for n, kind in graph.nodes(data="kind") if kind in ("input", "bias")]
    hops = nx.multi_source_dijkstra_path_length(graph, sources, weight=lambda u, v, d: 1)
    hidden = [n for n, kind in graph.nodes(data="kind") if kind == "hidden"]
    deepest = max((hops.get(n, 1) for n in hidden), default=0)
    for n, kind in graph.nodes(data="kind"):
        graph.nodes[n]["layer"] = {"input": 0, "bias": 0, "output": deepest + 1}.get(kind, hops.get(n, 1))
    for src, dst, attrs in graph.edges(data=True):
        attrs["recurrent"] = graph.nodes[dst]["layer"] <= graph.nodes[src]["layer"] and src != dst
    graph.graph.update(outputs=range(first_output, first_output + n_out), off=off)
    return graph


def _offset(fig, dx_pt: float, dy_pt: float):
    from matplotlib.transforms import ScaledTranslation

    return ScaledTranslation(dx_pt / 72, dy_pt / 72, fig.dpi_scale_trans)


def plot_network(controller: Controller, path: Path | str, disabled_modules: tuple[str, ...] = (),
                 title: str | None = None) -> None:
    """Draw ``controller``'s network to ``path`` (.svg, .png or .pdf)."""
    nx, plt = _networkx(), pyplot()
    graph = network_graph(controller, disabled_modules)
    pos = {n: (x, -y) for n, (x, y) in  # first input on top
           nx.multipartite_layout(graph, subset_key="layer", align="vertical", scale=1.0).items()}
    size = max(len([n for n, k in graph.nodes(data="kind") if k in ("input", "bias")]),
               len(controller.outputs), 6)
    columns = 1 + max(layer for _, layer in graph.nodes(data="layer"))
    fig, ax = plt.subplots(figsize=(3.2 + 1.8 * columns, 1.0 + 0.42 * size), layout="constrained")
    off = graph.graph["off"]

    def node_colour(n: int) -> str:
        kind, module = graph.nodes[n]["kind"], graph.nodes[n]["module"]
        if kind == "hidden":
            return OFF if module in off else MODULE_COLOURS[module % len(MODULE_COLOURS)]
        return {"input": "0.93", "bias": "0.6", "output": "gold"}[kind]

    heaviest = max([abs(w) for _, _, w in graph.edges(data="weight")] or [1.0])

    def look(d: dict) -> dict:
        return {"width": 0.3 + 2.7 * abs(d["weight"]) / heaviest, "alpha": 0.75,
                "colour": (EXCITATORY if d["weight"] > 0 else INHIBITORY) if d["enabled"] else OFF,
                "style": "solid" if d["enabled"] else "dotted"}

    for recurrent, bend in ((False, "arc3,rad=0.0"), (True, "arc3,rad=0.35")):
        edges = [(u, v) for u, v, r in graph.edges(data="recurrent") if r == recurrent and u != v]
        if edges:
            looks = [look(graph.edges[e]) for e in edges]
            nx.draw_networkx_edges(graph, pos, edgelist=edges, ax=ax, connectionstyle=bend, arrowsize=7,
                                   node_size=260, alpha=0.75, width=[k["width"] for k in looks],
                                   edge_color=[k["colour"] for k in looks], style=[k["style"] for k in looks])
    for n in nx.nodes_with_selfloops(graph):  # a small ring on the node (networkx's are page-sized)
        k = look(graph.edges[n, n])
        ax.plot(*pos[n], marker="o", markersize=13, markerfacecolor="none", markeredgecolor=k["colour"],
                markeredgewidth=k["width"], alpha=k["alpha"], ls="", zorder=0,
                transform=ax.transData + _offset(fig, 0, 9))
    nx.draw_networkx_nodes(graph, pos, ax=ax, node_size=260, node_color=[node_colour(n) for n in graph.nodes],
                           edgecolors="0.3", linewidths=0.6)
    for n, (x, y) in pos.items():
        kind, label = graph.nodes[n]["kind"], graph.nodes[n]["label"]
        if kind in ("input", "bias"):
            ax.annotate(label, (x, y), xytext=(-9, 0), textcoords="offset points", ha="right", va="center", fontsize=8)
        elif kind == "output":
            ax.annotate(label, (x, y), xytext=(9, 0), textcoords="offset points", ha="left", va="center", fontsize=8)
        else:
            ax.annotate(label, (x, y), ha="center", va="center", fontsize=5.5)
    handles = [plt.Line2D([], [], color=EXCITATORY, lw=2, label="weight > 0"),
               plt.Line2D([], [], color=INHIBITORY, lw=2, label="weight < 0")]
    for k, name in enumerate(controller.modules):
        colour = OFF if k in off else MODULE_COLOURS[k % len(MODULE_COLOURS)]
        handles.append(plt.Line2D([], [], marker="o", ls="", color=colour, markeredgecolor="0.3",
                                  label=f"module {name}" + (" (off)" if k in off else "")))
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.01), ncol=min(len(handles), 4),
              fontsize=8, frameon=False)
    n_hidden = sum(1 for _, k in graph.nodes(data="kind") if k == "hidden")
    ax.set_title(title or f"{controller.robot_name}: {n_hidden} hidden nodes, {graph.number_of_edges()} links "
                 "(one network, run as the right and the left copy)", fontsize=9)
    ax.margins(x=0.25, y=0.04)
    ax.axis("off")
    save_figure(fig, path, dpi=130)
