#!/usr/bin/env python3
"""Reads an MCAP file back and prints what it holds as JSON: per topic its schema, encodings,
message count, first and last log time and whether its messages come in time order; whether the
whole file is in time order; and a few decoded values (the map grid's size, the ground truth's
entities at a time, a laser scan's size, image formats) for tests to compare with the run's files.

usage: tools/export_mcap.sh --check RUN.mcap [--at SECONDS]
"""
import argparse
import json
import sys

from mcap.reader import make_reader
from mcap_protobuf.decoder import DecoderFactory


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("mcap")
    ap.add_argument("--at", type=float, default=None, help="decode /truth/entities at this time (s)")
    a = ap.parse_args()
    out = {"topics": {}, "time_ordered": True, "messages": 0}
    at_ns = None if a.at is None else int(round(a.at * 1e9))
    with open(a.mcap, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        out["library"] = reader.get_header().library
        last = -1
        for schema, channel, message, decoded in reader.iter_decoded_messages(log_time_order=False):
            t = message.log_time
            topic = out["topics"].setdefault(channel.topic, {
                "schema": schema.name, "schema_encoding": schema.encoding, "message_encoding": channel.message_encoding,
                "count": 0, "first_ns": t, "last_ns": t, "ordered": True})
            if t < topic["last_ns"]:
                topic["ordered"] = False
            if t < last:
                out["time_ordered"] = False
            last = t
            topic["count"] += 1
            topic["last_ns"] = t
            out["messages"] += 1
            if channel.topic == "/map" and "map" not in out:
                out["map"] = {"columns": decoded.column_count, "cells": len(decoded.data), "cell_size": decoded.cell_size.x,
                              "frame_id": decoded.frame_id}
            elif channel.topic == "/truth/entities" and at_ns is not None and t == at_ns:
                out["entities_at"] = {e.id: [round(p.pose.position.x, 4), round(p.pose.position.y, 4)]
                                      for e in decoded.entities for p in (list(e.cylinders) + list(e.cubes))[:1]}
            elif channel.topic.endswith("/scan") and "scan" not in out:
                out["scan"] = {"topic": channel.topic, "ranges": len(decoded.ranges), "frame_id": decoded.frame_id,
                               "start_angle": decoded.start_angle, "end_angle": decoded.end_angle}
            elif channel.topic.endswith("/image") and "image" not in out:
                out["image"] = {"topic": channel.topic, "format": decoded.format, "bytes": len(decoded.data),
                                "jpeg": decoded.data[:2] == b"\xff\xd8"}
    json.dump(out, sys.stdout, indent=1)
    print()


if __name__ == "__main__":
    main()
