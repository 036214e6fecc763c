"""Writes maps/dis_labs.graph, the DIS labs' patrol graph, in patrolling_sim's format
(../shared/data/maps/README.md): the corridor arms' centre lines every few metres, one vertex
in front of each door and one inside each lab and room. Edge costs are the straight lengths in
pixels. Run from the repository root: python3 tools/gen_dis_graph.py"""
import math

RES, W, H = 0.05, 880, 640  # maps/dis_labs.yaml: 0.05 m/px, 44 x 32 m, origin (0, 0)
V = [
    (2.9, 3.1),    # 0  corridor corner
    (7.0, 3.1),    # 1
    (12.0, 3.1),   # 2  lab door
    (20.0, 3.1),   # 3  lab_b door
    (28.0, 3.1),   # 4  lab_c door
    (36.0, 3.1),   # 5  lab_d door
    (38.5, 3.1),   # 6  east end (short of the exit)
    (2.9, 9.0),    # 7
    (2.9, 15.0),   # 8  room_1 door
    (2.9, 22.0),   # 9  room_2 door
    (2.9, 27.0),   # 10 north end (short of the exit)
    (12.0, 6.3),   # 11 lab (south of its table)
    (20.0, 7.5),   # 12 lab_b
    (28.0, 7.5),   # 13 lab_c
    (36.5, 7.5),   # 14 lab_d
    (7.0, 15.0),   # 15 room_1
    (7.0, 22.0),   # 16 room_2
]
E = [(0, 1), (1, 2), (2, 3), (3, 4), (4, 5), (5, 6), (0, 7), (7, 8), (8, 9), (9, 10),
     (2, 11), (3, 12), (4, 13), (5, 14), (8, 15), (9, 16)]


def compass(dx, dy):
    a = math.degrees(math.atan2(dy, dx))
    return ["E", "NE", "N", "NW", "W", "SW", "S", "SE"][round(a / 45) % 8]


def main():
    nbr = {i: [] for i in range(len(V))}
    for a, b in E:
        nbr[a].append(b)
        nbr[b].append(a)
    px = [(round(x / RES), round(y / RES)) for x, y in V]
    out = [str(len(V)), str(W), str(H), str(RES), "0", "0", ""]
    for i, (x, y) in enumerate(px):
        out += [str(i), str(x), str(y), str(len(nbr[i]))]
        for j in nbr[i]:
            dx, dy = px[j][0] - x, px[j][1] - y
            out += [str(j), compass(dx, dy), str(round(math.hypot(dx, dy)))]
        out.append("")
    with open("maps/dis_labs.graph", "w") as f:
        f.write("\n".join(out) + "\n")


if __name__ == "__main__":
    main()
