#!/usr/bin/env python3
"""Write crates/scan/data/aruco/dictionaries.txt from OpenCV's predefined ArUco dictionaries.

The marker codes are OpenCV's data (objdetect's predefined dictionaries, Apache-2.0; see
crates/scan/data/aruco/README.md); lucent must read the same codes to find the same markers.
Needs opencv-contrib-python(-headless) ≥ 4.7:

    python3 scripts/aruco_dictionaries.py > crates/scan/data/aruco/dictionaries.txt

Format: a line `set NAME SIZE COUNT` starts a set of COUNT markers of SIZE × SIZE bits, one per
line as hexadecimal of the bits read row by row from the top left (first bit most significant;
1 = white). A line `dict NAME SET COUNT MAX_CORRECTION_BITS` names the first COUNT markers of a
set with OpenCV's maximum number of correctable bits (before its errorCorrectionRate).
"""

import cv2

A = cv2.aruco
SETS = ["DICT_4X4_1000", "DICT_5X5_1000", "DICT_6X6_1000", "DICT_7X7_1000", "DICT_ARUCO_ORIGINAL",
        "DICT_ARUCO_MIP_36h12", "DICT_APRILTAG_16h5", "DICT_APRILTAG_25h9", "DICT_APRILTAG_36h10",
        "DICT_APRILTAG_36h11"]


def codes(d):
    out = []
    for i in range(d.bytesList.shape[0]):
        bits = A.Dictionary.getBitsFromByteList(d.bytesList[i:i + 1], d.markerSize).flatten()
        v = 0
        for b in bits:
            v = (v << 1) | (1 if b else 0)
        out.append(v)
    return out


def main():
    sets = {}
    print("# OpenCV %s predefined ArUco dictionaries (scripts/aruco_dictionaries.py)" % cv2.__version__)
    for name in SETS:
        d = A.getPredefinedDictionary(getattr(A, name))
        c = codes(d)
        sets[name] = c
        print("set %s %d %d" % (name, d.markerSize, len(c)))
        width = (d.markerSize * d.markerSize + 3) // 4
        for v in c:
            print("%0*x" % (width, v))
    for name in sorted(n for n in dir(A) if n.startswith("DICT_")):
        d = A.getPredefinedDictionary(getattr(A, name))
        c = codes(d)
        src = next(s for s in SETS if sets[s][:len(c)] == c and len(bin(max(sets[s]) | 1)) <= d.markerSize ** 2 + 2
                   and A.getPredefinedDictionary(getattr(A, s)).markerSize == d.markerSize)
        print("dict %s %s %d %d %d" % (name, src, len(c), d.maxCorrectionBits, getattr(A, name)))


if __name__ == "__main__":
    main()
