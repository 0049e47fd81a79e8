  } catch (e) {
    fail(e);
  }
