"""Fingers: five digits of three joints and a tip on each hand a rig has, read off the mesh itself.

    from autorig.hands.stage import read_fingers, skin_with_fingers
    fingers = read_fingers(vertices, faces, names, joints)        # after the body's joints are placed
    weights = skin_with_fingers(vertices, faces, joints, parents, names, fingers)   # body, then each hand
    names, parents, joints, weights = fingers.appended(names, parents, joints, weights)

For each side whose rig has ``{side}_wrist``, ``{side}_elbow`` and ``{side}_hand_end``, the full-resolution
surface beyond the wrist is read (``region``): its fingertips are the prominent extremities of the geodesic
distance from the wrist, each finger the skin beyond the saddle where it parts from its neighbour, the thumb
the one that parts nearest the wrist and stands apart (``digits``); joints go at fractions of each digit's
path measured on the corpus (``joints``). The weights (``stage.skin_with_fingers``) are the body's bone heat,
then each hand's own at its full resolution with the finger bones. A hand that does not show five digits (a
mitten, a fist, a hand too coarse to see them) gets none, and ``Fingers.status`` says so. Joints are ``{side}_{finger}1..3`` and
``{side}_{finger}_end``; ``names`` holds their Mixamo, Unreal and Unity names.
"""
