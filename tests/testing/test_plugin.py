"""The fixtures reach a user's own test suite through the pytest11 entry point."""

pytest_plugins = ["pytester"]


def test_fixtures_in_a_fresh_test_suite(pytester):
    pytester.makepyfile(
        """
        import math
        import py_trees

        def test_first(blackboard, fake_robot, manual_clock, fake_perception, mission_factory):
            assert fake_robot.clock is manual_clock
            assert manual_clock.now() == 0.0
            assert fake_robot.safety_state == "ready"
            assert fake_perception.name == "Perception" and fake_perception.world == []
            m = mission_factory(route=["blue"], navigation={"clearance_mm": 350})
            assert m.route == ["blue"] and m.navigation.clearance_mm == 350
            assert m.navigation.bypass_distance_mm == 800  # the rest kept
            py_trees.blackboard.Blackboard.set("/marknav/target", "left over")

        def test_second(blackboard):
            assert not py_trees.blackboard.Blackboard.exists("/marknav/target")
        """
    )
    result = pytester.runpytest("-p", "no:cacheprovider")
    result.assert_outcomes(passed=2)
