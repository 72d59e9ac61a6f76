#!/usr/bin/env python3
"""Reads back the bag test/ros/record_test.sh recorded from the demo (two seconds): exit 0 when
it holds what the README's recording recipe promises, else prints what is wrong and exits 1."""
import sys

import rosbag
from sensor_msgs import point_cloud2


def main(path):
    problems = []
    with rosbag.Bag(path) as bag:
        info = bag.get_type_and_topic_info()
        types = {topic: t.msg_type for topic, t in info.topics.items()}
        counts = {topic: t.message_count for topic, t in info.topics.items()}
        print("read_bag: %s, %.2f s: %s" % (path, bag.get_end_time() - bag.get_start_time(), counts))
        expected = {"/fluid_sim/stats": "fluid_msgs/SolverStats", "/fluid_sim/particles": "sensor_msgs/PointCloud2",
                    "/fluid_sim/contact_wrenches": "fluid_msgs/ContactWrenchArray", "/tf": "tf2_msgs/TFMessage"}
        for topic, msg_type in expected.items():
            if types.get(topic) != msg_type:
                problems.append("%s: type %s, expected %s" % (topic, types.get(topic), msg_type))
        if counts.get("/fluid_sim/stats", 0) < 2:
            problems.append("only %d stats messages in two seconds" % counts.get("/fluid_sim/stats", 0))
        if counts.get("/fluid_sim/particles", 0) < 2:
            problems.append("only %d clouds in two seconds" % counts.get("/fluid_sim/particles", 0))
        sim_times = [m.sim_time for _, m, _ in bag.read_messages(topics=["/fluid_sim/stats"])]
        if len(sim_times) >= 2 and not all(b >= a for a, b in zip(sim_times, sim_times[1:])):
            problems.append("the stats' simulated time goes backwards")
        if len(sim_times) >= 2 and not sim_times[-1] > sim_times[0]:
            problems.append("the simulated time does not advance (%s)" % sim_times[:3])
        clouds = 0
        for _, cloud, _ in bag.read_messages(topics=["/fluid_sim/particles"]):
            clouds += 1
            names = [f.name for f in cloud.fields]
            for field in ("x", "y", "z", "pressure"):
                if field not in names:
                    problems.append("a cloud without the field %s (fields %s)" % (field, names))
            n = cloud.width * cloud.height
            if n == 0 or n > 500:
                problems.append("a cloud of %d points (expected 1-500 with max_points 500)" % n)
            pts = list(point_cloud2.read_points(cloud, field_names=("x", "y", "z"), skip_nans=True))
            if len(pts) != n:
                problems.append("a cloud whose points do not read back (%d of %d)" % (len(pts), n))
        frames = set()
        # robot_state_publisher puts the moving joints' links on /tf, the fixed ones' (the paddle,
        # on the fixed wrist) on /tf_static.
        for _, tf, _ in bag.read_messages(topics=["/tf", "/tf_static"]):
            frames.update(t.child_frame_id for t in tf.transforms)
        if not {"arm", "paddle"} <= frames:
            problems.append("tf without the robot's arm and paddle links (frames %s)" % sorted(frames))
    for p in problems:
        print("read_bag: " + p)
    print("read_bag: %d clouds read back; %s" % (clouds, "ok" if not problems else "%d problems" % len(problems)))
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
