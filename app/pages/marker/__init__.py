"""Step 3, Marker: train the end-effector marker, then check its 3D location on stereo pairs.

The page is page.py, a small controller: the step's options and results are the Qt-free model
(model.py); one panel per tab (*_panel.py) and the stereo line (stereo_bar.py) say what was
chosen (`options()`) and draw from the model's events; the helpers the page holds start the
work through its task and put what it returns into the model: training.py (the training image,
training, the project's saved marker), locating.py (live pair, verification), studies.py
(comparison, imaging conditions) and autopilot.py (the classroom demo). The work they run on
worker threads is app/jobs/marker.py. The chapter's chain, one tab each:

1. **Training** (core.marker.training.train_marker, worker thread): a training image loaded
   from a file or taken with the left camera (cameras opened on the Setup page) or the virtual
   lab's camera; the outer black square is found
   automatically (drawn dashed) or inside a crop rectangle the user drags; SIFT keypoints,
   the fitted outline and its reference point (the intersection of the diagonals) are drawn.
   The marker goes into the project (marker.npz, marker_training.png) and to
   ``state.marker``.
2. **Live pair** (virtual lab: the robot at a random visible pose, "Next pose"; with cameras:
   "Capture pair", the robot where it is): in both
   images the SIFT matches (agreeing / not), the homography's outline, the region of
   interest, the Canny edge pixels and the fitted outline, the reference point; the 3D point
   (mm, left camera frame) with its σ and, in the virtual lab, its error against the truth.
3. **SSD correlation**: the criteria curve along the epipolar line (Fig. 16) and the
   window-size sweep (Fig. 17).
4. **Verification** over N random robot poses (worker, progress, Cancel): detection rate,
   median and RMS 3D error against the truth, rejection reasons counted.
5. **Compare markers** (the virtual lab's marker comparison, Fig. 11).
6. **Conditions** (virtual lab; work in app/jobs/marker_conditions.py): one pair under a chosen
   light level, occluded share and tilt, and the robustness sweep over all three (detection
   rate, median and 95th-percentile 3D error, markers wrongly accepted) as a table and plots.

The stereo rectification comes from the project's stereo.yaml (else the Stereo step's
result); in the virtual lab without one, the page offers a clearly labelled preview with the
lab's true cameras. The step is complete once a marker is trained, saved and located at
least once (marker_verification.json records the last verification).
"""
