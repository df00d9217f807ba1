"""The settings file: typed values with defaults, atomic writes, and recovery from damage."""

from __future__ import annotations

import json
import logging
import os
import stat

import pytest

from app.errors import SettingsError
from app.records import settings as settings_module
from app.records.settings import (
    ENV_CONFIG_DIR,
    SETTINGS_NAME,
    Settings,
    config_dir,
    load_settings,
    save_settings,
    settings_path,
    update_settings,
)
from core.trial import TrialParameters


@pytest.fixture
def config(tmp_path, monkeypatch):
    folder = tmp_path / "config"
    monkeypatch.setenv(ENV_CONFIG_DIR, str(folder))
    return folder


def test_config_dir_comes_from_the_environment_or_platformdirs(tmp_path):
    assert config_dir({ENV_CONFIG_DIR: str(tmp_path)}) == tmp_path
    default = config_dir({ENV_CONFIG_DIR: "  "})
    assert default.name == "rehab-console"
    assert settings_path({}) == default / SETTINGS_NAME


def test_missing_file_gives_defaults(config):
    loaded = load_settings()
    assert loaded == Settings()
    assert (loaded.data_dir, loaded.flip_x, loaded.flip_y, loaded.window_geometry) == (
        None, False, False, None)
    assert loaded.trial_parameters() is None


def test_round_trip_through_the_file(config):
    params = TrialParameters(radius_m=0.12, controller="ctpid")
    saved = Settings(data_dir="/srv/rehab", flip_x=True, window_geometry="AdnQywADAAAAAA==")
    saved = saved.with_trial_parameters(params)
    path = save_settings(saved)
    assert path == config / SETTINGS_NAME
    loaded = load_settings()
    assert loaded == saved
    assert loaded.trial_parameters() == params
    assert json.loads(path.read_text())["settings_version"] == 1

    updated = update_settings(flip_y=True)
    assert (updated.flip_x, updated.flip_y) == (True, True)
    assert load_settings() == updated


def test_wrong_types_are_refused_when_set(config):
    with pytest.raises(SettingsError, match="flip_x = 'yes' is not allowed: give true or false"):
        Settings(flip_x="yes")
    with pytest.raises(SettingsError, match="data_dir"):
        update_settings(data_dir="")
    assert not (config / SETTINGS_NAME).exists()


def test_write_is_atomic_and_a_failed_write_keeps_the_old_file(config, monkeypatch):
    save_settings(Settings(flip_x=True))
    before = (config / SETTINGS_NAME).read_bytes()

    def refuse(src, dst):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(settings_module.os, "replace", refuse)
    with pytest.raises(SettingsError, match=r"No space left on device.*previous settings are"):
        save_settings(Settings(flip_x=False, window_geometry="x"))
    assert (config / SETTINGS_NAME).read_bytes() == before
    assert sorted(os.listdir(config)) == [SETTINGS_NAME]  # no temporary left behind


def test_unwritable_config_folder_says_what_to_do(tmp_path, monkeypatch):
    blocker = tmp_path / "file"
    blocker.write_text("in the way")
    monkeypatch.setenv(ENV_CONFIG_DIR, str(blocker / "config"))
    with pytest.raises(SettingsError, match=f"cannot write the settings.*{ENV_CONFIG_DIR}"):
        save_settings(Settings())


@pytest.mark.parametrize("content", [b"{\"flip_x\": tru", b"[1, 2]", b"\xff\xfe\x00garbage"])
def test_corrupt_file_is_set_aside_and_defaults_used_with_a_warning(config, caplog, content):
    config.mkdir()
    (config / SETTINGS_NAME).write_bytes(content)
    with caplog.at_level(logging.WARNING, logger="app.records.settings"):
        loaded = load_settings()
    assert loaded == Settings()
    aside = list(config.glob(f"{SETTINGS_NAME}.corrupt-*"))
    assert len(aside) == 1
    assert aside[0].read_bytes() == content
    assert not (config / SETTINGS_NAME).exists()
    assert "kept as settings.json.corrupt-" in caplog.text
    # The next save starts a fresh file; the damaged one stays for inspection.
    save_settings(loaded.replace(flip_y=True))
    assert load_settings().flip_y is True
    assert len(list(config.glob(f"{SETTINGS_NAME}.corrupt-*"))) == 1


def test_unknown_keys_survive_a_save(config):
    config.mkdir()
    (config / SETTINGS_NAME).write_text(json.dumps({
        "flip_y": True, "window_geometry": "g", "from_a_newer_console": {"theme": "dark"},
    }))
    loaded = load_settings()
    assert (loaded.flip_x, loaded.flip_y, loaded.window_geometry) == (False, True, "g")
    save_settings(loaded.replace(data_dir="/data"))
    stored = json.loads((config / SETTINGS_NAME).read_text())
    assert stored["from_a_newer_console"] == {"theme": "dark"}
    assert stored["data_dir"] == "/data"
    assert stat.S_IMODE((config / SETTINGS_NAME).stat().st_mode) == 0o600


def test_a_wrong_typed_setting_sets_the_file_aside_and_keeps_only_its_data_folder(
        config, caplog, tmp_path):
    """A value of the wrong type is refused like a damaged file (issue 28 #14), not taken
    for its default beside the others; the data folder the file names is kept."""
    config.mkdir()
    (config / SETTINGS_NAME).write_text(json.dumps({
        "data_dir": str(tmp_path / "clinic"), "flip_x": "sometimes", "flip_y": True}))
    with caplog.at_level(logging.WARNING, logger="app.records.settings"):
        loaded = load_settings()
    assert loaded == Settings(data_dir=str(tmp_path / "clinic"))
    assert "flip_x = 'sometimes'" in caplog.text
    assert len(list(config.glob(f"{SETTINGS_NAME}.corrupt-*"))) == 1


@pytest.mark.parametrize("value", [123, "", "   ", True, [], {"path": "/data"}])
def test_a_wrong_typed_data_folder_is_never_replaced_by_the_default(config, monkeypatch,
                                                                     value):
    """`"data_dir": 123` or `""` once sent the console, silently, to an empty default
    registry: the data folder is now unknown and every command says so in one line."""
    from app.errors import DataDirError
    from app.records.datadir import ENV_DATA_DIR, locate_data_dir

    monkeypatch.delenv(ENV_DATA_DIR, raising=False)
    config.mkdir()
    (config / SETTINGS_NAME).write_text(json.dumps({"data_dir": value, "flip_x": True}))
    with pytest.raises(DataDirError, match=r"settings file .*damaged or cannot be read"):
        locate_data_dir()


@pytest.mark.parametrize("text", [
    '{"data_dir": "/clinic", "robot_height": NaN}',
    '{"data_dir": "/clinic", "flip_x": Infinity}',
    '{"settings_version": "1", "flip_x": true}',
    '{"settings_version": true}',
    '{"last_trial_parameters": ' + "[" * 200_000 + "]" * 200_000 + "}",
])
def test_settings_json_that_cannot_be_trusted_is_refused_in_one_line(
        config, tmp_path, monkeypatch, capsys, text):
    """NaN, a version of the wrong type, 200,000 levels of nesting: set aside; a command
    says so in one line (exit 2) when the data folder cannot be read back from it, and
    never runs on the default folder's registry."""
    from tests.app.cli.running import run

    monkeypatch.delenv("REHAB_DATA_DIR", raising=False)
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "home" / "data"))
    config.mkdir()
    (config / SETTINGS_NAME).write_text(text)
    loaded = load_settings()
    assert len(list(config.glob(f"{SETTINGS_NAME}.corrupt-*"))) == 1
    if '"/clinic"' in text:
        assert loaded.data_dir == "/clinic"
        return
    assert loaded.damaged
    code, _, err = run(["patients"], capsys)
    assert code == 2
    assert err.count("\n") == 1, err
    assert "settings file" in err
    assert not (tmp_path / "home").exists()  # no default registry was started


def test_stale_trial_parameters_are_ignored_with_a_warning(config, caplog):
    stale = TrialParameters().to_dict() | {"radius_m": 9.0}
    with caplog.at_level(logging.WARNING, logger="app.records.settings"):
        assert Settings(last_trial_parameters=stale).trial_parameters() is None
        renamed = TrialParameters().to_dict() | {"old_field": 1}
        assert Settings(last_trial_parameters=renamed).trial_parameters() is None
    assert "radius_m" in caplog.text
    assert "old_field" in caplog.text


def test_a_truncated_file_keeps_its_data_folder(config, tmp_path, monkeypatch):
    """A truncated settings.json used to send the console to the default data folder, so
    the next patient landed in a new, empty registry."""
    from app.records.datadir import ENV_DATA_DIR, locate_data_dir

    monkeypatch.delenv(ENV_DATA_DIR, raising=False)
    chosen = tmp_path / "clinic data"
    full = json.dumps({"data_dir": str(chosen), "flip_x": True,
                       "last_trial_parameters": TrialParameters().to_dict()})
    config.mkdir()
    (config / SETTINGS_NAME).write_text(full[: len(full) // 2])  # cut mid-way
    assert locate_data_dir().root == chosen
    assert load_settings().data_dir == str(chosen)  # written back whole
    assert len(list(config.glob(f"{SETTINGS_NAME}.corrupt-*"))) == 1


def test_a_damaged_byte_in_the_data_folder_s_name_is_not_read_back_as_another_folder(
        config, tmp_path, monkeypatch):
    """A byte of the folder's name set to one that is not UTF-8 (the corruption bench's
    'byte set to 253') was read back with a replacement character, '/tmp/r\ufffdg/data':
    the console went on with a folder no one named. The folder is now unknown, refused."""
    from app.errors import DataDirError
    from app.records.datadir import ENV_DATA_DIR, locate_data_dir

    monkeypatch.delenv(ENV_DATA_DIR, raising=False)
    config.mkdir()
    text = json.dumps({"data_dir": str(tmp_path / "reg" / "data"), "flip_x": True}).encode()
    at = text.index(b"reg") + 1
    (config / SETTINGS_NAME).write_bytes(text[:at] + b"\xfd" + text[at + 1:])
    with pytest.raises(DataDirError, match=r"settings file .*corrupt-.* is damaged"):
        locate_data_dir()
    assert len(list(config.glob(f"{SETTINGS_NAME}.corrupt-*"))) == 1


def test_a_damaged_file_without_its_data_folder_is_refused_until_someone_looks(
        config, tmp_path, monkeypatch):
    from app.errors import DataDirError
    from app.records.datadir import ENV_DATA_DIR, locate_data_dir

    monkeypatch.delenv(ENV_DATA_DIR, raising=False)
    config.mkdir()
    (config / SETTINGS_NAME).write_text('{"flip_x": true, "data_d')
    for _ in range(2):  # at this start and at the next
        with pytest.raises(DataDirError,
                           match=r"settings file .*corrupt-.* is damaged or cannot be read"):
            locate_data_dir()
    monkeypatch.setenv(ENV_DATA_DIR, str(tmp_path / "d"))
    assert locate_data_dir().root == tmp_path / "d"
    monkeypatch.delenv(ENV_DATA_DIR)
    for kept in config.glob(f"{SETTINGS_NAME}.corrupt-*"):
        kept.unlink()  # the therapist looked, and chose the default
    assert locate_data_dir().source == "default"


def test_a_linked_settings_file_is_read_and_saved_through_the_link(config, tmp_path):
    """Saving replaced the user's link by a plain file: their own file (a dotfiles
    repository's) silently stopped being the one in use. As git and editors do, the
    console now writes through to the target and the link stays a link."""
    mine = tmp_path / "dotfiles" / "rehab.json"
    mine.parent.mkdir()
    mine.write_text(json.dumps({"data_dir": "/srv/rehab", "flip_x": True}))
    config.mkdir()
    link = config / SETTINGS_NAME
    link.symlink_to(mine)
    assert load_settings().flip_x is True
    update_settings(flip_y=True)
    assert link.is_symlink()
    assert os.readlink(link) == str(mine)
    assert json.loads(mine.read_text())["flip_y"] is True
    assert load_settings().data_dir == "/srv/rehab"
    assert sorted(p.name for p in config.iterdir()) == [SETTINGS_NAME]  # no temporary left


def test_a_damaged_linked_file_is_set_aside_beside_itself_and_the_link_kept(config, tmp_path,
                                                                            caplog):
    mine = tmp_path / "dotfiles" / "rehab.json"
    mine.parent.mkdir()
    mine.write_text('{"data_dir": "/srv/rehab", "flip_x": tru')
    config.mkdir()
    link = config / SETTINGS_NAME
    link.symlink_to(mine)
    with caplog.at_level(logging.WARNING):
        loaded = load_settings()
    assert loaded.data_dir == "/srv/rehab"
    assert link.is_symlink()
    assert os.readlink(link) == str(mine)
    assert json.loads(mine.read_text())["data_dir"] == "/srv/rehab"  # saved through
    kept = list(mine.parent.glob("rehab.json.corrupt-*"))
    assert len(kept) == 1
    assert kept[0].read_text().endswith("tru")


def test_a_link_to_nothing_is_saved_through_and_a_loop_refused(config, tmp_path):
    config.mkdir()
    link = config / SETTINGS_NAME
    mine = tmp_path / "rehab.json"
    link.symlink_to(mine)
    assert load_settings() == Settings()
    save_settings(Settings(flip_x=True))
    assert link.is_symlink()
    assert json.loads(mine.read_text())["flip_x"] is True
    link.unlink()
    link.symlink_to(link)
    assert load_settings().damaged == str(link)  # its data folder is unknown, not guessed
    with pytest.raises(SettingsError, match=r"cannot write the settings: .*loops"):
        save_settings(Settings())
    assert link.is_symlink()
