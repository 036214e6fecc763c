#!/usr/bin/env python3
"""Writes a Vigil run as an MCAP file with Foxglove's well-known schemas (protobuf).

Called by tools/export_mcap.sh (from `vigil export-mcap RUN_DIR`) with the scene `vigil` read
(the map grid, cameras, entities). Every message's log time is the simulated time of what it
shows (nanoseconds from the run's start); messages are written in that order. Topics (frame
"map", the building's frame, unless said):

  /map                      foxglove.Grid           the occupancy map (0 free, 100 occupied, -1 unknown)
  /tf                       foxglove.FrameTransforms map -> each camera (x forward, z up)
  /cameras                  foxglove.SceneUpdate    each camera as an arrow with its field of view
  /truth/entities           foxglove.SceneUpdate    robots, people, objects at each ground-truth tick
  /truth/events             foxglove.SceneUpdate    the ground truth's events where they happened
  /robots/<id>/pose         foxglove.PoseInFrame    the pose the robot believes (robots.jsonl)
  /robots/<id>/path         foxglove.SceneUpdate    what is left of its planned path (robots.jsonl)
  /robots/<id>/scan         foxglove.LaserScan      its laser scans (scans.jsonl), pose = the laser's
  /robots/log               foxglove.Log            the robots' goal and task events
  /cameras/<id>/image       foxglove.CompressedImage the camera's left view (JPEG, frame <id>)
  /cameras/<id>/tracks      foxglove.SceneUpdate    its tracks (tracks.jsonl)
  /events                   foxglove.SceneUpdate    the video server's incidents (events.jsonl)
  /events/log               foxglove.Log            every truth and reported event as a line
"""
import argparse
import json
import math
import os
import sys

import cv2
import foxglove
from foxglove import channels as ch
from foxglove import messages as m


def fail(path, line, key, message, code=2):
    where = path + (":%d" % line if line else "")
    print("vigil export-mcap: %s: %s%s" % (where, key + ": " if key else "", message), file=sys.stderr)
    sys.exit(code)


def read_lines(path):
    """(line number, object) of a JSON Lines file; nothing when it is missing."""
    if not os.path.exists(path):
        return
    with open(path) as f:
        for n, line in enumerate(f, 1):
            if not line.strip():
                continue
            try:
                obj = json.loads(line)
            except ValueError as e:
                fail(path, n, "", "not JSON (%s)" % e)
            if not isinstance(obj, dict):
                fail(path, n, "", "not a JSON object")
            yield n, obj


def need(obj, key, path, n):
    if key not in obj:
        fail(path, n, key, "missing")
    return obj[key]


def ts(t_ns):
    return m.Timestamp(sec=int(t_ns // 1_000_000_000), nsec=int(t_ns % 1_000_000_000))


def colour(hexstr, a=1.0):
    try:
        v = int(hexstr[1:7], 16)
        return m.Color(r=((v >> 16) & 255) / 255.0, g=((v >> 8) & 255) / 255.0, b=(v & 255) / 255.0, a=a)
    except (ValueError, TypeError):
        return m.Color(r=0.5, g=0.5, b=0.5, a=a)


def quat_yaw(yaw, pitch=0.0, roll=0.0):
    # z-y'-x'' rotation: yaw about z, then pitch about the new y (down positive), then roll about
    # the view axis x.
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    return m.Quaternion(x=cy * cp * sr - sy * sp * cr, y=cy * sp * cr + sy * cp * sr,
                        z=sy * cp * cr - cy * sp * sr, w=cy * cp * cr + sy * sp * sr)


def pose(x, y, z=0.0, yaw=0.0, pitch=0.0, roll=0.0):
    return m.Pose(position=m.Vector3(x=x, y=y, z=z), orientation=quat_yaw(yaw, pitch, roll))


def text(label, x, y, z, c=None):
    return m.TextPrimitive(pose=pose(x, y, z), billboard=True, font_size=14.0, scale_invariant=True,
                           color=c or m.Color(r=0, g=0, b=0, a=1), text=label)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("run")
    ap.add_argument("--scene", required=True, help="the scene vigil export-mcap wrote")
    ap.add_argument("--out", required=True)
    ap.add_argument("--image-rate", type=float, default=5.0)
    ap.add_argument("--jpeg-quality", type=int, default=80)
    a = ap.parse_args()
    run = a.run
    with open(a.scene) as f:
        scene = json.load(f)
    summary_path = os.path.join(run, "summary.json")
    try:
        with open(summary_path) as f:
            summary = json.load(f)
    except (OSError, ValueError) as e:
        fail(summary_path, 0, "", "cannot read it (%s)" % e)
    duration_ns = int(round(float(summary.get("sim_seconds", 0)) * 1e9))
    ents = scene["entities"]
    msgs = []  # (t_ns, order, channel key, message)
    seq = [0]

    def add(t_ns, key, msg):
        seq[0] += 1
        msgs.append((int(t_ns), seq[0], key, msg))

    # The map.
    g = scene["map"]
    hexdata = g["occupancy_hex"]
    grid = m.Grid(timestamp=ts(0), frame_id="map", pose=pose(g["origin_x"], g["origin_y"]), column_count=g["width"],
                  cell_size=m.Vector2(x=g["resolution"], y=g["resolution"]), row_stride=g["width"], cell_stride=1,
                  fields=[m.PackedElementField(name="occupancy", offset=0, type=m.PackedElementFieldNumericType.Int8)],
                  data=bytes.fromhex(hexdata))
    add(0, "/map", grid)

    # Cameras: frames, and arrows with their fields of view on the floor.
    transforms, cam_entities = [], []
    for c in scene["cameras"]:
        transforms.append(m.FrameTransform(timestamp=ts(0), parent_frame_id="map", child_frame_id=c["id"],
                                           translation=m.Vector3(x=c["x"], y=c["y"], z=c["z"]),
                                           rotation=quat_yaw(c["yaw"], c["pitch"], c.get("roll", 0.0))))
        reach = 8.0
        pts = [m.Point3(x=c["x"], y=c["y"], z=0.01)]
        for k in range(13):
            ang = c["yaw"] - c["hfov"] / 2 + c["hfov"] * k / 12
            pts.append(m.Point3(x=c["x"] + reach * math.cos(ang), y=c["y"] + reach * math.sin(ang), z=0.01))
        pts.append(pts[0])
        cam_entities.append(m.SceneEntity(
            timestamp=ts(0), frame_id="map", id=c["id"], frame_locked=False,
            arrows=[m.ArrowPrimitive(pose=pose(c["x"], c["y"], c["z"], c["yaw"], c["pitch"]), shaft_length=0.5,
                                     shaft_diameter=0.06, head_length=0.2, head_diameter=0.15,
                                     color=m.Color(r=0.0, g=0.3, b=0.7, a=1))],
            lines=[m.LinePrimitive(type=m.LinePrimitiveLineType.LineStrip, pose=pose(0, 0), thickness=2.0,
                                   scale_invariant=True, points=pts, color=m.Color(r=0.3, g=0.6, b=1.0, a=0.8))],
            texts=[text(c["id"], c["x"], c["y"], c["z"] + 0.3, m.Color(r=0.0, g=0.3, b=0.7, a=1))]))
    add(0, "/tf", m.FrameTransforms(transforms=transforms))
    add(0, "/cameras", m.SceneUpdate(entities=cam_entities))

    # The ground truth: entities at each tick, then its events.
    gt_path = os.path.join(run, "ground_truth.jsonl")
    if not os.path.exists(gt_path):
        fail(gt_path, 0, "", "missing")
    shown = set()
    truth_events = []
    ticks = 0
    for n, j in read_lines(gt_path):
        kind = j.get("type")
        if kind == "tick":
            t = need(j, "t_ns", gt_path, n)
            entities, now = [], set()
            for e in need(j, "entities", gt_path, n):
                eid, x, y = e.get("id", ""), need(e, "x", gt_path, n), need(e, "y", gt_path, n)
                yaw = e.get("yaw", 0.0)
                info = ents.get(eid, {"kind": e.get("kind", "?"), "colour": "#808080"})
                now.add(eid)
                kw = dict(timestamp=ts(t), frame_id="map", id=eid, frame_locked=False)
                if info["kind"] in ("robot", "person"):
                    r, h = info.get("radius", 0.25), info.get("height", 0.5)
                    kw["cylinders"] = [m.CylinderPrimitive(pose=pose(x, y, h / 2, yaw), size=m.Vector3(x=2 * r, y=2 * r, z=h),
                                                           bottom_scale=1.0, top_scale=1.0, color=colour(info["colour"]))]
                    kw["arrows"] = [m.ArrowPrimitive(pose=pose(x, y, h + 0.05, yaw), shaft_length=r, shaft_diameter=0.04,
                                                     head_length=0.12, head_diameter=0.1, color=m.Color(r=0, g=0, b=0, a=1))]
                    kw["texts"] = [text(eid, x, y, h + 0.3)]
                else:
                    sx, sy, sz = info.get("size", [0.4, 0.2, 0.4])
                    z = e.get("z", 0.0)
                    kw["cubes"] = [m.CubePrimitive(pose=pose(x, y, z + sz / 2, yaw), size=m.Vector3(x=sx, y=sy, z=sz),
                                                   color=colour(info["colour"]))]
                    kw["texts"] = [text(eid, x, y, z + sz + 0.2)]
                ent = m.SceneEntity(**kw)
                entities.append(ent)
            gone = [m.SceneEntityDeletion(timestamp=ts(t), type=m.SceneEntityDeletionType.MatchingId, id=i)
                    for i in sorted(shown - now)]
            shown = now
            add(t, "/truth/entities", m.SceneUpdate(deletions=gone, entities=entities))
            ticks += 1
        elif kind == "event":
            truth_events.append(j)
    for i, e in enumerate(truth_events):
        t = e.get("t_ns", 0)
        x, y = e.get("x", 0.0), e.get("y", 0.0)
        add(t, "/truth/events", m.SceneUpdate(entities=[m.SceneEntity(
            timestamp=ts(t), frame_id="map", id="truth_%d" % i, frame_locked=False,
            spheres=[m.SpherePrimitive(pose=pose(x, y, 0.05), size=m.Vector3(x=1.2, y=1.2, z=0.1), color=m.Color(r=0.9, g=0, b=0, a=0.4))],
            texts=[text("truth: " + e.get("kind", ""), x, y, 1.0, m.Color(r=0.8, g=0, b=0, a=1))])]))
        add(t, "/events/log", m.Log(timestamp=ts(t), level=m.LogLevel.Info, name="truth",
                                    message="truth %s %s at (%.2f, %.2f)" % (e.get("kind", ""), ",".join(e.get("people", [])), x, y)))

    # What the robots' controllers reported.
    robots_path = os.path.join(run, "robots.jsonl")
    for n, j in read_lines(robots_path):
        t = need(j, "t_ns", robots_path, n)
        rid = need(j, "robot", robots_path, n)
        add(t, "/robots/%s/pose" % rid, m.PoseInFrame(timestamp=ts(t), frame_id="map",
                                                     pose=pose(need(j, "x", robots_path, n), need(j, "y", robots_path, n), 0.0, j.get("yaw", 0.0))))
        plan = j.get("path") or []
        if len(plan) >= 2:
            add(t, "/robots/%s/path" % rid, m.SceneUpdate(entities=[m.SceneEntity(
                timestamp=ts(t), frame_id="map", id=rid + "_path", frame_locked=False,
                lines=[m.LinePrimitive(type=m.LinePrimitiveLineType.LineStrip, pose=pose(0, 0), thickness=3.0,
                                       scale_invariant=True, points=[m.Point3(x=p[0], y=p[1], z=0.02) for p in plan],
                                       color=m.Color(r=0.0, g=0.63, b=0.78, a=1.0))])]))
        else:
            add(t, "/robots/%s/path" % rid, m.SceneUpdate(deletions=[m.SceneEntityDeletion(
                timestamp=ts(t), type=m.SceneEntityDeletionType.MatchingId, id=rid + "_path")]))
        if j.get("event"):
            add(t, "/robots/log", m.Log(timestamp=ts(t), level=m.LogLevel.Warning if j["event"] in ("goal_failed", "task_rejected") else m.LogLevel.Info,
                                        name=rid, message="%s %s%s (mode %s, goal %.2f %.2f)" % (
                                            rid, j["event"], (": " + j["detail"]) if j.get("detail") else "", j.get("mode", ""),
                                            j.get("goal_x", 0.0), j.get("goal_y", 0.0))))
    scans_path = os.path.join(run, "scans.jsonl")
    for n, j in read_lines(scans_path):
        t = need(j, "t_ns", scans_path, n)
        rid = need(j, "robot", scans_path, n)
        lx, ly, lyaw = need(j, "laser", scans_path, n)
        ranges = [float(r) for r in need(j, "ranges", scans_path, n)]
        a0, inc = need(j, "angle_min", scans_path, n), need(j, "angle_increment", scans_path, n)
        add(t, "/robots/%s/scan" % rid, m.LaserScan(timestamp=ts(t), frame_id="map", pose=pose(lx, ly, 0.2, lyaw),
                                                   start_angle=a0, end_angle=a0 + inc * max(0, len(ranges) - 1),
                                                   ranges=ranges, intensities=[]))

    # Each camera's tracks.
    tracks_path = os.path.join(run, "tracks.jsonl")
    CLASS = {"person": m.Color(r=0.55, g=0.17, b=0.89, a=0.6), "bag": m.Color(r=0.88, g=0.44, b=0.0, a=0.6)}
    by_stamp = {}
    for n, j in read_lines(tracks_path):
        key = (need(j, "t_ns", tracks_path, n), j.get("camera", ""))
        by_stamp.setdefault(key, []).append((n, j))
    for (t, cam), rows in sorted(by_stamp.items()):
        entities = []
        for n, j in rows:
            x, y = need(j, "x", tracks_path, n), need(j, "y", tracks_path, n)
            h = j.get("height", 0.3) or 0.3
            w = j.get("width", 0.4) or 0.4
            entities.append(m.SceneEntity(
                timestamp=ts(t), frame_id="map", id="%s_%s" % (cam, j.get("id", 0)), frame_locked=False,
                lifetime=m.Duration(sec=0, nsec=300_000_000),
                cubes=[m.CubePrimitive(pose=pose(x, y, h / 2), size=m.Vector3(x=w, y=w, z=h),
                                       color=CLASS.get(j.get("class"), m.Color(r=0.4, g=0.4, b=0.4, a=0.6)))],
                texts=[text("%s %s" % (j.get("class", ""), j.get("id", 0)), x, y, h + 0.2)]))
        add(t, "/cameras/%s/tracks" % cam, m.SceneUpdate(entities=entities))

    # The video server's incidents.
    events_path = os.path.join(run, "events.jsonl")
    for n, j in read_lines(events_path):
        t = need(j, "t_ns", events_path, n)
        pos = j.get("map") or [0.0, 0.0, 0.0]
        if j.get("cancelled"):  # the server withdrew the incident: its marker goes
            add(t, "/events", m.SceneUpdate(deletions=[m.SceneEntityDeletion(
                timestamp=ts(t), type=m.SceneEntityDeletionType.MatchingId, id="event_%s" % j.get("id", n))]))
            add(t, "/events/log", m.Log(timestamp=ts(t), level=m.LogLevel.Info, name=j.get("camera", "server"),
                                        message="withdrawn %s %d" % (j.get("kind", ""), j.get("id", 0))))
            continue
        add(t, "/events", m.SceneUpdate(entities=[m.SceneEntity(
            timestamp=ts(t), frame_id="map", id="event_%s" % j.get("id", n), frame_locked=False,
            cubes=[m.CubePrimitive(pose=pose(pos[0], pos[1], 1.2, math.pi / 4), size=m.Vector3(x=0.5, y=0.5, z=0.5),
                                   color=m.Color(r=0.0, g=0.3, b=0.9, a=0.7))],
            texts=[text("%s (%s)" % (j.get("kind", ""), j.get("camera", "")), pos[0], pos[1], 1.8, m.Color(r=0, g=0.2, b=0.8, a=1))])]))
        add(t, "/events/log", m.Log(timestamp=ts(t), level=m.LogLevel.Warning, name=j.get("camera", "server"),
                                    message="reported %s %d at (%.2f, %.2f)%s" % (j.get("kind", ""), j.get("id", 0), pos[0], pos[1],
                                                                                  "")))

    # Camera images, from the run's videos, at --image-rate.
    images = 0
    if a.image_rate > 0:
        for c in scene["cameras"]:
            path = None
            for ext in (".mp4", ".avi"):
                p = os.path.join(run, "cameras", c["id"] + ext)
                if os.path.exists(p):
                    path = p
                    break
            if not path:
                continue
            cap = cv2.VideoCapture(path)
            if not cap.isOpened():
                fail(path, 0, "", "cannot open the video")
            # The frame nearest each multiple of 1 / image_rate, up to the run's end.
            wanted = set()
            i = 0
            while i / a.image_rate <= duration_ns / 1e9 + 1e-9:
                wanted.add(int(round(i * c["rate_hz"] / a.image_rate)))
                i += 1
            k = -1
            while True:
                ok, frame = cap.read()
                if not ok:
                    break
                k += 1
                if k not in wanted:
                    continue
                t = int(round(k * 1e9 / c["rate_hz"]))
                ok, jpg = cv2.imencode(".jpg", frame, [cv2.IMWRITE_JPEG_QUALITY, a.jpeg_quality])
                add(t, "/cameras/%s/image" % c["id"], m.CompressedImage(timestamp=ts(t), frame_id=c["id"], data=jpg.tobytes(), format="jpeg"))
                images += 1

    # Channels, then every message in time order.
    kinds = {m.Grid: ch.GridChannel, m.FrameTransforms: ch.FrameTransformsChannel, m.SceneUpdate: ch.SceneUpdateChannel,
             m.PoseInFrame: ch.PoseInFrameChannel, m.LaserScan: ch.LaserScanChannel, m.Log: ch.LogChannel,
             m.CompressedImage: ch.CompressedImageChannel}
    msgs.sort(key=lambda x: (x[0], x[1]))
    if os.path.exists(a.out):
        os.remove(a.out)
    writer = foxglove.open_mcap(a.out, allow_overwrite=True)
    channels = {}
    for t, _, key, msg in msgs:
        if key not in channels:
            channels[key] = kinds[type(msg)](key)
        channels[key].log(msg, log_time=t)
    writer.close()
    size = os.path.getsize(a.out)
    print("wrote %s (%.1f MB): %d messages on %d topics, %d ground-truth ticks, %d camera images" % (
        a.out, size / 1e6, len(msgs), len(channels), ticks, images))


if __name__ == "__main__":
    main()
