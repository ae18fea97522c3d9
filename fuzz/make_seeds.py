#!/usr/bin/env python3
"""Writes the seed corpora of the fuzz harnesses (fuzz/corpus/<harness>/): small valid inputs
of every format, so libFuzzer starts from the structure instead of from nothing.
Run from the repository root: python3 fuzz/make_seeds.py (the corpora are committed)."""
import os
import struct

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "corpus")


def put(harness, name, data):
    d = os.path.join(ROOT, harness)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, name), "wb") as f:
        f.write(data if isinstance(data, bytes) else data.encode())


points = [(0.0, 0.0, 0.0, 0x808080), (1.0, 0.5, 0.25, 0xff0000), (-1.5, 2.0, 0.1, 0x00ff00)]

# --- clouds: first byte 0 = PCD, 1 = PLY (bit 1: drop NaN points) ---------------------------
ascii_pcd = ("# .PCD v0.7\nVERSION 0.7\nFIELDS x y z rgb\nSIZE 4 4 4 4\nTYPE F F F U\nCOUNT 1 1 1 1\n"
             "WIDTH 3\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 3\nDATA ascii\n" +
             "".join(f"{x} {y} {z} {c}\n" for x, y, z, c in points))
put("cloud", "pcd_ascii", b"\x00" + ascii_pcd.encode())
header = ascii_pcd.split("DATA ascii")[0] + "DATA binary\n"
body = b"".join(struct.pack("<fffI", x, y, z, c) for x, y, z, c in points)
put("cloud", "pcd_binary", b"\x00" + header.encode() + body)
put("cloud", "pcd_xyz_nan", b"\x02" + ("VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
                                       "WIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA ascii\n1 2 3\nnan nan nan\n").encode())
ply_head = ("ply\nformat {fmt} 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
            "property uchar red\nproperty uchar green\nproperty uchar blue\nelement face 1\n"
            "property list uchar int vertex_indices\nend_header\n")
put("cloud", "ply_ascii", b"\x01" + (ply_head.format(fmt="ascii") +
                                     "".join(f"{x} {y} {z} {(c >> 16) & 255} {(c >> 8) & 255} {c & 255}\n"
                                             for x, y, z, c in points) + "3 0 1 2\n").encode())
put("cloud", "ply_binary", b"\x01" + ply_head.format(fmt="binary_little_endian").encode() +
    b"".join(struct.pack("<fffBBB", x, y, z, (c >> 16) & 255, (c >> 8) & 255, c & 255) for x, y, z, c in points) +
    struct.pack("<Biii", 3, 0, 1, 2))

# --- TUM ---------------------------------------------------------------------------------------
put("tum", "poses", "# timestamp tx ty tz qx qy qz qw\n0.0 0 0 0 0 0 0 1\n1.5 1.0 0.2 0 0 0 0.3826834 0.9238795\n\n"
    "2.0 2.0 0.5 0.1 0.1 0 0 0.9949874\n")

# --- configuration files: first byte 0 space, 1 parameter set, 2 experiment, 3 manifest, 4 trials.csv
put("config", "space", b"\x00" + b"name: s\nparameters:\n  a: {type: float, low: 0, high: 1, default: 0.5}\n"
    b"  b: {type: int, low: 1, high: 10, default: 3, log: false}\n")
put("config", "params", b"\x01" + b"r_N: 0.2\nv_K: 0.1\nt_K: 1.0\nr_D: 0.2\nn_C: 3\nt_C: 0.5\nr_LRF: 0.2\nv_TF: 0.5\nn_TF: 8\n")
put("config", "params_ros2", b"\x01" + b"map_matcher:\n  ros__parameters:\n    r_N: 0.3\n    n_C: 4\n")
put("config", "experiment", b"\x02" + b"name: e\nspace: s.yaml\ndataset: d\nview: subsequent\nreference: odometry\n"
    b"measure: {e_star: 0.4, m_star: auto, w_v: 0.5}\nbudget: {evaluations: 30}\n"
    b"optimizer: {acquisition: log_ei, seed: 1, initial_points: 8}\nfidelity: {subset: 4, z: 2}\n")
put("config", "manifest", b"\x03" + b"format: maptune-dataset\nversion: 1\nid: 0123456789abcdef\nname: tiny\n"
    b"voxel_size: 0.04\nruns: [run00]\n")
put("config", "trials", b"\x04" + b"evaluation,p,m,v,eps,failed,from_store,wall_s,pair_s,fidelity,elapsed_s,origin,"
    b"r_N,v_K,t_K,r_D,n_C,t_C,r_LRF,v_TF,n_TF,error\n"
    b"1,0.81,33,0.85,0.76,0,0,3.2,0.49,1,3.2,start,0.2,0.1,1.0,0.2,3,0.5,0.2,0.5,8,\n"
    b"2,0.0,0,0.0,0.0,1,0,1.4,0.3,1,4.6,initial,0.25,0.31,0.39,0.12,8,0.04,0.59,0.61,71,no match\n")

# --- DDS messages: first byte picks the type, then CDR (little endian, encapsulation header) --
class Cdr:
    def __init__(self):
        self.b = bytearray()

    def align(self, n):
        while len(self.b) % n:
            self.b.append(0)

    def u32(self, v):
        self.align(4)
        self.b += struct.pack("<I", v)
        return self

    def u64(self, v):
        self.align(8)
        self.b += struct.pack("<Q", v)
        return self

    def f64(self, v):
        self.align(8)
        self.b += struct.pack("<d", v)
        return self

    def boolean(self, v):
        self.b.append(1 if v else 0)
        return self

    def string(self, s):
        data = s.encode() + b"\0"
        self.u32(len(data))
        self.b += data
        return self

    def strings(self, items):
        self.u32(len(items))
        for s in items:
            self.string(s)
        return self

    def values(self, items):
        self.u32(len(items))
        for name, v in items:
            self.string(name).f64(v)
        return self

    def pairs(self, n):
        self.u32(n)
        for i in range(n):
            self.string(f"run00/submap00{i}|run00/submap00{i + 1}").boolean(True)
            for k in range(16):
                self.f64(1.0 if k % 5 == 0 else 0.0)
            self.f64(0.5).u32(0).string("")
        return self

    def message(self, selector):
        return bytes([selector]) + b"\x00\x01\x00\x00" + bytes(self.b)


params = [("r_N", 0.2), ("n_C", 3.0)]
put("messages", "request", Cdr().string("e/1/1").string("e").string("abc").string("complete").string("lru")
    .string("1").string("cf72").values(params).strings(["icp_max_iterations=10"]).message(0))
put("messages", "reply", Cdr().string("e/1/1").boolean(True).string("").boolean(False).string("k").values(params)
    .pairs(2).f64(1.5).message(1))
put("messages", "task", Cdr().string("x-t1").string("w1").string("abc").string("complete").string("lru")
    .string("cf72").values(params).strings(["a|b", "b|c"]).u32(10000).string("1").strings([]).message(2))
put("messages", "result", Cdr().string("x-t1").string("w1").boolean(True).string("").pairs(1).message(3))
put("messages", "status", Cdr().string("w1").string("lru").string("1").string("cf72").u32(2).u32(1).u64(7)
    .boolean(True).strings(["x-t1"]).boolean(False).message(4))
put("messages", "announcement", Cdr().string("abc").string("tiny").string("srv").u32(1).string("manifest.yaml")
    .u64(120).string("0123").message(5))
chunk = Cdr().string("c/1").u32(0).u32(2).string("manifest.yaml").u32(3)
chunk.b += b"\x01\x02\x03"
put("messages", "chunk", chunk.string("").message(6))
# Regression input: a chunk count of 4e9 once made a dataset mirror allocate 4e9 slots.
huge = Cdr().string("c/1").u32(0).u32(4000000000).string("manifest.yaml").u32(0)
put("messages", "chunk_count_4e9", huge.string("").message(6))
put("messages", "best", Cdr().string("demo").u32(30).u32(28).f64(0.87).values(params).f64(0.86).f64(0.01)
    .values(params).message(7))
print("seeds in", ROOT)
