"""Ego-motion from the radar's Doppler: the fit of one radar and of a rig (one radar is a rig of
one), the rig's odometry, and the calibration of the mountings from a drive."""
