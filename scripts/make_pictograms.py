#!/usr/bin/env python3
"""Draws the protocol's action pictograms (rig-configs/protocols/pictograms/*.svg).

A right hand seen from above on the pad; the parts that touch are filled red, a
blue arrow shows a push or pull. The participant page mirrors them for the left
hand. Run again after changing a drawing: python3 scripts/make_pictograms.py
"""
import math
import os
import sys

OUT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "rig-configs", "protocols", "pictograms")
SKIN, TOUCH, LINE, PAD, ARROW = "#f2c9a5", "#d7263d", "#5b3a29", "#3a3f47", "#1b6ec2"

# Fingers of a right hand, palm down, seen from above: (name, x of base centre, length, angle deg from up).
FINGERS = [("thumb", 150, 70, -55), ("index", 178, 96, -6), ("middle", 206, 104, 0),
           ("ring", 234, 96, 5), ("pinky", 258, 76, 12)]


def finger(name, bx, length, angle, touch, curled):
    if curled:
        length *= 0.6
    w = 24 if name != "thumb" else 27
    by = 190
    fill = TOUCH if name in touch else SKIN
    tip = TOUCH if (name + "_tip") in touch else None
    g = f'<g transform="rotate({angle} {bx} {by})">'
    g += f'<rect x="{bx - w / 2}" y="{by - length}" width="{w}" height="{length + 10}" rx="{w / 2}" fill="{fill}" stroke="{LINE}" stroke-width="3"/>'
    if tip:
        g += f'<circle cx="{bx}" cy="{by - length + w / 2}" r="{w / 2 - 2}" fill="{tip}"/>'
    return g + "</g>"


def hand(touch=(), curled=False, dx=0, dy=0, rotate=0):
    parts = [f'<g transform="translate({dx} {dy}) rotate({rotate} 210 220)">']
    parts += [finger(n, x, l, a, touch, curled and n != "thumb") for n, x, l, a in FINGERS]
    palm = TOUCH if "palm" in touch else SKIN
    parts.append(f'<rect x="160" y="180" width="110" height="100" rx="34" fill="{palm}" stroke="{LINE}" stroke-width="3"/>')
    parts.append('</g>')
    return "".join(parts)


def arrow(x1, y1, x2, y2):
    a = math.atan2(y2 - y1, x2 - x1)
    hx, hy = x2 - 18 * math.cos(a - 0.5), y2 - 18 * math.sin(a - 0.5)
    kx, ky = x2 - 18 * math.cos(a + 0.5), y2 - 18 * math.sin(a + 0.5)
    return (f'<line x1="{x1}" y1="{y1}" x2="{x2}" y2="{y2}" stroke="{ARROW}" stroke-width="9" stroke-linecap="round"/>'
            f'<polygon points="{x2},{y2} {hx:.1f},{hy:.1f} {kx:.1f},{ky:.1f}" fill="{ARROW}"/>')


def svg(body, pad=True):
    s = '<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 420 320" width="420" height="320">'
    if pad:
        s += f'<rect x="20" y="40" width="380" height="260" rx="14" fill="{PAD}"/>'
        s += '<rect x="34" y="54" width="352" height="232" rx="6" fill="#596270"/>'
    return s + body + "</svg>\n"


def dots(points):
    return "".join(f'<circle cx="{x}" cy="{y}" r="9" fill="{TOUCH}"/>' for x, y in points)


DRAWINGS = {
    "calibration": svg(dots([(60, 80), (360, 80), (360, 260), (60, 260)]) +
                       '<path d="M60 80 L360 80 L360 260 L60 260 Z" fill="none" stroke="#ffffff" stroke-dasharray="10 8" stroke-width="3"/>' +
                       hand(("index_tip",), dx=-20, dy=20)),
    "press_index_finger": svg(hand(("index_tip",))),
    "index_pull_towards": svg(hand(("index_tip",)) + arrow(120, 90, 120, 250)),
    "index_push_left": svg(hand(("index_tip",)) + arrow(150, 60, 40, 60)),
    "index_push_away": svg(hand(("index_tip",)) + arrow(120, 250, 120, 90)),
    "index_push_right": svg(hand(("index_tip",)) + arrow(280, 60, 390, 60)),
    "press_palm": svg(hand(("palm",))),
    "press_palm_and_fingers": svg(hand(("palm", "thumb", "index", "middle", "ring", "pinky"))),
    "press_fingers": svg(hand(("index", "middle", "ring", "pinky"))),
    "fingers_one_by_one_flat": svg(hand(("thumb_tip", "index_tip", "middle_tip", "ring_tip", "pinky_tip")) +
                                   '<text x="40" y="290" font-size="26" fill="#ffffff" font-family="sans-serif">1 2 3 4 5</text>'),
    "fingers_one_by_one_cupped": svg(hand(("thumb_tip", "index_tip", "middle_tip", "ring_tip", "pinky_tip"), curled=True) +
                                     '<text x="40" y="290" font-size="26" fill="#ffffff" font-family="sans-serif">1 2 3 4 5</text>'),
    "fingertips_push_away": svg(hand(("index_tip", "middle_tip", "ring_tip", "pinky_tip"), curled=True) + arrow(90, 260, 90, 90)),
    "fingertips_pull_towards": svg(hand(("index_tip", "middle_tip", "ring_tip", "pinky_tip"), curled=True) + arrow(90, 90, 90, 260)),
    "grasp_edge_thumb_down_uncurled": svg(hand(("thumb", "index", "middle", "ring", "pinky"), dy=40) +
                                          '<text x="36" y="36" font-size="24" fill="#333" font-family="sans-serif">edge, thumb down</text>'),
    "grasp_edge_thumb_down_curled": svg(hand(("thumb", "index_tip", "middle_tip", "ring_tip", "pinky_tip"), curled=True, dy=40) +
                                        '<text x="36" y="36" font-size="24" fill="#333" font-family="sans-serif">edge, thumb down</text>'),
    "grasp_edge_thumb_up_uncurled": svg(hand(("index", "middle", "ring", "pinky"), dy=40) +
                                        '<text x="36" y="36" font-size="24" fill="#333" font-family="sans-serif">edge, thumb up</text>'),
    "grasp_edge_thumb_up_curled": svg(hand(("index_tip", "middle_tip", "ring_tip", "pinky_tip"), curled=True, dy=40) +
                                      '<text x="36" y="36" font-size="24" fill="#333" font-family="sans-serif">edge, thumb up</text>'),
    "pinch_thumb_down": svg(hand(("thumb_tip", "index_tip"), curled=True) + arrow(110, 120, 150, 150)),
    "pinch_thumb_up": svg(hand(("index_tip",), curled=True) + arrow(110, 120, 150, 150)),
    "draw_word": svg(hand(("index_tip",), dx=40) +
                     '<path d="M50 250 q20 -60 40 0 t40 0 t40 0" fill="none" stroke="#ffffff" stroke-width="6"/>'),
    "pinch_zoom": svg(hand(("thumb_tip", "index_tip")) + arrow(140, 150, 80, 210) + arrow(180, 110, 240, 50)),
}


def main():
    os.makedirs(OUT, exist_ok=True)
    for name, text in DRAWINGS.items():
        with open(os.path.join(OUT, name + ".svg"), "w") as f:
            f.write(text)
    print(f"{len(DRAWINGS)} pictograms in {os.path.normpath(OUT)}", file=sys.stderr)


if __name__ == "__main__":
    main()
