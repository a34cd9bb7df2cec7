"""The IR camera of the tests that run a whole case for something else than the camera's reading
(studies, refinement studies): the camera's path runs, cheaply. Its readings are tested against
analytic values in tests/test_instruments.py.
"""

#: 4 rotation phases per tooth pass, 2 x 2 rays per pixel and one aim, against the default 24,
#: 8 x 8 and 4 x 4: a run of the refinement tests' small case takes 3.6 s instead of 7.9 s (the
#: camera 1.5 s instead of 3.6 s; measured on 1 rank).
QUICK_CAMERA = {"phases": 4, "subsamples": 2, "aim_offsets": 1}
