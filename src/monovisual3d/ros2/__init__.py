"""Live on the robot: a ROS 2 node over DDS that needs no ROS installation (extra ``[ros2]``).

The node speaks ROS 2's wire protocol directly through Cyclone DDS (the ``cyclonedds`` package): ROS 2 topic
``/x`` is DDS topic ``rt/x`` (:mod:`.names`), message ``pkg/msg/Name`` is DDS type ``pkg::msg::dds_::Name_``
(:mod:`.msgs`, byte for byte the CDR of the ROS 2 Humble and Jazzy definitions), with the QoS ROS 2 uses
(:mod:`.dds`). It reads ``sensor_msgs/CameraInfo``, ``vision_msgs/Detection2DArray``, ``/tf`` and ``/tf_static``
and publishes ``vision_msgs/Detection3DArray``, RViz markers, a JSON status and the next view.

Modules by concept:

- :mod:`.names`: ROS 2 names on DDS; :mod:`.config`: the node's options (:class:`~.config.NodeConfig`, :class:`~.config.Topics`);
- :mod:`.msgs`: the message types; :mod:`.dds`: domain, QoS, readers and writers;
- :mod:`.tf_buffer`: live TF with waiting lookups; :mod:`.tracks`: track ids; :mod:`.outputs`: results -> messages;
- :mod:`.live`: one session (views -> estimates), free of DDS; :mod:`.next_view`: the next view as a camera or tool pose;
- :mod:`.node`: the node (:class:`~.node.FruitNode`); :mod:`.play`: a session published as a robot would.

Reading ROS messages into the library's objects is :mod:`monovisual3d.io.ros_messages`, shared with the bag importer.
Nothing here is imported by ``import monovisual3d``; the modules that use DDS raise an ImportError naming the
``[ros2]`` extra when ``cyclonedds`` is missing. See docs/ros2.md.
"""
