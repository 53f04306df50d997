-- The session index as pvcap 0.1 created it (schema version 1), for the migration test.
CREATE TABLE session (
  id INTEGER PRIMARY KEY,
  started_wall_ns INTEGER NOT NULL,
  started_host_ns INTEGER NOT NULL,
  ended_host_ns INTEGER,
  end_reason TEXT,
  pvcap_version TEXT NOT NULL,
  rig_name TEXT NOT NULL,
  rig_path TEXT NOT NULL,
  rig_config TEXT NOT NULL,
  simulated INTEGER NOT NULL
);
CREATE TABLE devices (
  id INTEGER PRIMARY KEY,
  kind TEXT NOT NULL,
  name TEXT NOT NULL UNIQUE,
  vendor TEXT, model TEXT, serial TEXT, address TEXT, firmware TEXT,
  settings_json TEXT NOT NULL
);
CREATE TABLE video_files (
  id INTEGER PRIMARY KEY,
  device_id INTEGER NOT NULL REFERENCES devices(id),
  path TEXT NOT NULL UNIQUE,
  codec TEXT NOT NULL,
  pixel_format TEXT NOT NULL,
  width INTEGER NOT NULL,
  height INTEGER NOT NULL
);
CREATE TABLE frames (
  device_id INTEGER NOT NULL REFERENCES devices(id),
  connection INTEGER NOT NULL,
  sequence INTEGER NOT NULL,
  frame_id INTEGER NOT NULL,
  device_ns INTEGER NOT NULL,
  host_ns INTEGER NOT NULL,
  aravis_system_ns INTEGER NOT NULL,
  status TEXT NOT NULL,
  kept INTEGER NOT NULL,
  reason TEXT,
  video_file_id INTEGER REFERENCES video_files(id),
  video_index INTEGER
);
CREATE INDEX frames_by_time ON frames(device_id, host_ns);
CREATE INDEX frames_by_video ON frames(video_file_id, video_index);
CREATE TABLE pressure_frames (
  device_id INTEGER NOT NULL REFERENCES devices(id),
  connection INTEGER NOT NULL,
  sequence INTEGER NOT NULL,
  lost_before INTEGER NOT NULL,
  device_ns INTEGER NOT NULL,
  host_ns INTEGER NOT NULL,
  host_wait_ns INTEGER NOT NULL,
  grid_cols INTEGER NOT NULL, grid_rows INTEGER NOT NULL, grid_xscale INTEGER NOT NULL, grid_yscale INTEGER NOT NULL,
  payload BLOB NOT NULL
);
CREATE INDEX pressure_by_time ON pressure_frames(device_id, host_ns);
CREATE TABLE drops (
  device_id INTEGER NOT NULL REFERENCES devices(id),
  connection INTEGER NOT NULL,
  first_sequence INTEGER NOT NULL,
  count INTEGER NOT NULL,
  reason TEXT NOT NULL,
  host_ns INTEGER NOT NULL
);
CREATE TABLE events (
  host_ns INTEGER NOT NULL,
  kind TEXT NOT NULL,
  device_id INTEGER REFERENCES devices(id),
  message TEXT NOT NULL
);
CREATE TABLE stream_stats (
  device_id INTEGER NOT NULL REFERENCES devices(id),
  completed INTEGER NOT NULL, failures INTEGER NOT NULL, underruns INTEGER NOT NULL,
  resent_packets INTEGER NOT NULL, missing_packets INTEGER NOT NULL, queue_overflows INTEGER NOT NULL
);
