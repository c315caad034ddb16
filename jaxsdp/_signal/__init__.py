"""Signal processing: filtering, decimation, derivatives, regressor columns, preprocessing of a measured motion."""
